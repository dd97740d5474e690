// The map classifier: the PLY / PCD reader (the layouts fuse-map-export writes, and refusals of
// what it cannot read), exact counts on hand-made worlds, and fuse-sim --classify-map on a
// synthetic cloud of the urban scenario whose truth is computed by brute force.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "fuse/sim/cloud_reader.hpp"
#include "fuse/sim/map_classifier.hpp"
#include "fuse/sim/random.hpp"
#include "fuse/sim/scenario.hpp"

using namespace fuse::sim;
namespace fs = std::filesystem;

namespace {

fs::path temp_file(const std::string& name) {
  return fs::temp_directory_path() / ("fuse_sim_classify_" + std::to_string(::getpid()) + "_" + name);
}

void write_bytes(const fs::path& file, const std::string& header, const std::vector<float>& body, std::size_t cut = 0) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out << header;
  out.write(reinterpret_cast<const char*>(body.data()),
            static_cast<std::streamsize>(body.size() * sizeof(float) - cut));
}

std::vector<float> flat(const std::vector<Eigen::Vector3f>& points) {
  std::vector<float> xyz;
  for (const Eigen::Vector3f& p : points) xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
  return xyz;
}

// The headers of tools/fuse-map-export/cloud_writer.cpp.
std::string ply_header(std::size_t n) {
  return "ply\nformat binary_little_endian 1.0\ncomment frame world\nelement vertex " + std::to_string(n) +
         "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
}
std::string pcd_header(std::size_t n) {
  const std::string c = std::to_string(n);
  return "# .PCD v0.7 - Point Cloud Data file format\n# frame world\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F "
         "F\n"
         "COUNT 1 1 1\nWIDTH " +
         c + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + c + "\nDATA binary\n";
}

struct ExeRun {
  int code = -1;
  std::string out, err;
};

ExeRun run(const std::string& args) {
  const fs::path out = temp_file("stdout"), err = temp_file("stderr");
  const std::string cmd = std::string(FUSE_SIM_EXE) + " " + args + " >" + out.string() + " 2>" + err.string();
  const int status = std::system(cmd.c_str());
  ExeRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::stringstream o, e;
  o << std::ifstream(out).rdbuf();
  e << std::ifstream(err).rdbuf();
  r.out = o.str();
  r.err = e.str();
  fs::remove(out);
  fs::remove(err);
  return r;
}

std::size_t value(const std::string& text, const std::string& key) {
  const std::size_t at = text.find(key + ": ");
  if (at == std::string::npos) return static_cast<std::size_t>(-1);
  return std::stoull(text.substr(at + key.size() + 2));
}

}  // namespace

TEST(SimCloudReader, ReadsTheExportersPlyAndPcdAndOtherFieldLayouts) {
  const std::vector<Eigen::Vector3f> points = {{1.5f, -2.25f, 3.0f}, {0.0f, 0.0f, 0.0f}, {-7.0f, 8.0f, 1e3f}};
  const fs::path ply = temp_file("a.ply"), pcd = temp_file("a.pcd");
  write_bytes(ply, ply_header(points.size()), flat(points));
  write_bytes(pcd, pcd_header(points.size()), flat(points));
  EXPECT_EQ(read_cloud(ply.string()), points);
  EXPECT_EQ(read_cloud(pcd.string()), points);
  // Extra fields are skipped: PLY with an intensity before x, PCD with a 2-byte ring after z.
  std::vector<float> with_intensity;
  for (const Eigen::Vector3f& p : points) with_intensity.insert(with_intensity.end(), {42.0f, p.x(), p.y(), p.z()});
  write_bytes(ply,
              "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float intensity\nproperty float x\n"
              "property float y\nproperty float z\nend_header\n",
              with_intensity);
  EXPECT_EQ(read_cloud(ply.string()), points);
  {
    std::ofstream out(pcd, std::ios::binary | std::ios::trunc);
    out << "VERSION 0.7\nFIELDS x y z ring\nSIZE 4 4 4 2\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 3\nHEIGHT 1\nPOINTS 3\n"
           "DATA binary\n";
    for (const Eigen::Vector3f& p : points) {
      out.write(reinterpret_cast<const char*>(p.data()), 12);
      out.write("\x07\x00", 2);
    }
  }
  EXPECT_EQ(read_cloud(pcd.string()), points);
  write_bytes(ply, ply_header(0), {});
  EXPECT_TRUE(read_cloud(ply.string()).empty());
  fs::remove(ply);
  fs::remove(pcd);
}

TEST(SimCloudReader, RefusesWhatItCannotReadNamingTheProblem) {
  const std::vector<Eigen::Vector3f> points = {{1, 2, 3}, {4, 5, 6}};
  const fs::path f = temp_file("bad");
  const auto refused = [&](const std::string& expected) {
    try {
      read_cloud(f.string());
    } catch (const CloudReadError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(f.string()), std::string::npos) << e.what();
      return;
    }
    ADD_FAILURE() << "accepted, expected: " << expected;
  };
  write_bytes(f, ply_header(2), flat(points), 4);
  refused("truncated");
  write_bytes(f, ply_header(2), flat(points));
  { std::ofstream(f, std::ios::app) << "xx"; }
  refused("2 bytes after the last");
  write_bytes(
      f, "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
      {});
  refused("binary_little_endian 1.0 only");
  write_bytes(
      f, "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\nend_header\n",
      flat(points));
  refused("no float field 'z'");
  write_bytes(f,
              "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty uchar x\nproperty float y\n"
              "property float z\nend_header\n",
              flat(points));
  refused("field 'x' must be float");
  write_bytes(f, "ply\nformat binary_little_endian 1.0\nelement vertex 2\n", flat(points));
  refused("the header does not end");
  write_bytes(f, pcd_header(2), flat(points), 1);
  refused("truncated");
  std::string ascii = pcd_header(2);
  ascii.replace(ascii.find("DATA binary"), 11, "DATA ascii");
  write_bytes(f, ascii, {});
  refused("binary only");
  std::string wrong = pcd_header(2);
  wrong.replace(wrong.find("WIDTH 2"), 7, "WIDTH 3");
  write_bytes(f, wrong, flat(points));
  refused("WIDTH x HEIGHT");
  write_bytes(f, "hello world\n", {});
  refused("neither a PLY nor a PCD file");
  write_bytes(f, "", {});
  refused("empty file");
  std::vector<float> nan = flat(points);
  nan[4] = std::numeric_limits<float>::quiet_NaN();
  write_bytes(f, ply_header(2), nan);
  refused("point 1 has a non-finite coordinate");
  fs::remove(f);
  EXPECT_THROW(read_cloud(f.string()), CloudReadError);  // missing
}

TEST(SimMapClassifier, CountsAHandMadeCloudExactly) {
  World statics, swept;
  statics.add(Box{{0, 0, 0}, {1, 1, 1}, {}});
  statics.add(Plane{Eigen::Vector3d::UnitZ(), -10.0, {}});
  statics.build();
  swept.add(Box{{5, 0, 0}, {6, 1, 1}, {}});
  swept.build();
  const std::vector<Eigen::Vector3f> points = {
      {1.2f, 0.5f, 0.5f},   // 0.2 m off the box: static
      {0.5f, 0.5f, 0.5f},   // inside the box: static (clearance 0)
      {3.0f, 3.0f, -9.8f},  // 0.2 m above the plane: static
      {5.2f, 0.5f, 1.25f},  // 0.25 m above the swept box: ghost
      {5.5f, 0.5f, 0.5f},   // inside the swept box: ghost
      {1.4f, 0.5f, 0.5f},   // 0.4 m off the box: other
      {3.0f, 3.0f, 3.0f},   // nothing near: other
      {4.6f, 0.5f, 0.5f},   // 0.4 m off the swept box: other
  };
  const MapClassification c = classify_points(points, statics, swept, 0.3);
  EXPECT_EQ(c.map_points, 8u);
  EXPECT_EQ(c.static_points, 3u);
  EXPECT_EQ(c.ghost_points, 2u);
  EXPECT_EQ(c.other_points, 3u);
  EXPECT_EQ(classify_points(points, statics, swept, 0.45).other_points, 1u);  // a wider tolerance
}

// A synthetic cloud of the urban world: points on static surfaces, on the movers' paths (inside a
// box some mover occupied during the run, clear of the static world) and in the open. Its truth is
// computed here by brute force (World::clearance over every box, every swept box).
TEST(SimMapClassifier, ClassifiesASyntheticUrbanCloudLikeBruteForce) {
  const std::string scenario = "--scenario urban --seed 3 --duration 40";
  const Scenario s = make_scenario("urban", 3, 3);
  const double t0 = s.trajectory->t_begin(), tolerance = 0.3;
  const std::vector<Box> swept = s.traffic->swept_volume(t0, t0 + 40.0);
  Rng rng(99, Stream::kWorld);
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 600; ++i) {  // near building faces and the ground
    const Box& b =
        s.world.boxes()[static_cast<std::size_t>(rng.uniform_int(0, static_cast<int>(s.world.boxes().size()) - 1))];
    points.emplace_back(static_cast<float>(b.max.x() + rng.uniform(-0.2, 0.6)),
                        static_cast<float>(rng.uniform(b.min.y(), b.max.y())),
                        static_cast<float>(rng.uniform(0.0, b.max.z())));
  }
  for (int i = 0; i < 600; ++i) {  // in movers' boxes during the run, some above them
    const std::size_t m =
        static_cast<std::size_t>(rng.uniform_int(0, static_cast<int>(s.traffic->movers().size()) - 1));
    const Box b = s.traffic->box(m, t0 + rng.uniform(0.0, 40.0));
    points.emplace_back(static_cast<float>(rng.uniform(b.min.x(), b.max.x())),
                        static_cast<float>(rng.uniform(b.min.y(), b.max.y())),
                        static_cast<float>(rng.uniform(0.35, b.max.z() + 0.5)));
  }
  for (int i = 0; i < 300; ++i)  // above the street crossings: nothing there
    points.emplace_back(static_cast<float>(130.0 * rng.uniform_int(0, 5) + rng.uniform(-3.0, 3.0)),
                        static_cast<float>(110.0 * rng.uniform_int(0, 4) + rng.uniform(-3.0, 3.0)),
                        static_cast<float>(rng.uniform(3.0, 30.0)));
  MapClassification truth;
  truth.map_points = points.size();
  for (const Eigen::Vector3f& pf : points) {
    const Eigen::Vector3d p = pf.cast<double>();
    double to_swept = 1e9;
    for (const Box& b : swept) to_swept = std::min(to_swept, (b.min - p).cwiseMax(p - b.max).cwiseMax(0.0).norm());
    if (s.world.clearance(p) <= tolerance)
      ++truth.static_points;
    else if (to_swept <= tolerance)
      ++truth.ghost_points;
    else
      ++truth.other_points;
  }
  EXPECT_GT(truth.static_points, 300u);
  EXPECT_GT(truth.ghost_points, 300u);
  EXPECT_GT(truth.other_points, 300u);
  const fs::path ply = temp_file("map.ply"), pcd = temp_file("map.pcd");
  write_bytes(ply, ply_header(points.size()), flat(points));
  write_bytes(pcd, pcd_header(points.size()), flat(points));
  for (const fs::path& f : {ply, pcd}) {
    const ExeRun r = run(scenario + " --classify-map " + f.string());
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(value(r.out, "map_points"), truth.map_points) << r.out;
    EXPECT_EQ(value(r.out, "static_points"), truth.static_points) << r.out;
    EXPECT_EQ(value(r.out, "ghost_points"), truth.ghost_points) << r.out;
    EXPECT_EQ(value(r.out, "other_points"), truth.other_points) << r.out;
  }
  // The same cloud in an estimator's frame (the world turned 30 deg about z and moved), with the
  // estimate of that run: --map-trajectory moves it back and the counts are the same.
  const Eigen::Isometry3d T_map_world =
      Eigen::Translation3d(5.0, -3.0, 1.0) * Eigen::AngleAxisd(30.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ());
  std::vector<Eigen::Vector3f> moved;
  for (const Eigen::Vector3f& p : points) moved.push_back((T_map_world * p.cast<double>()).cast<float>());
  const fs::path moved_ply = temp_file("moved.ply"), estimate = temp_file("estimate.tum");
  write_bytes(moved_ply, ply_header(moved.size()), flat(moved));
  {
    std::ofstream tum(estimate);
    tum.precision(17);
    for (double t = t0; t <= t0 + 40.0; t += 0.5) {
      const Eigen::Vector3d p = T_map_world * s.trajectory->state(t).p;
      tum << t << ' ' << p.x() << ' ' << p.y() << ' ' << p.z() << " 0 0 0 1\n";
    }
  }
  const ExeRun aligned = run(scenario + " --classify-map " + moved_ply.string() + " --map-trajectory " + estimate.string());
  ASSERT_EQ(aligned.code, 0) << aligned.err;
  EXPECT_EQ(value(aligned.out, "static_points"), truth.static_points) << aligned.out;
  EXPECT_EQ(value(aligned.out, "ghost_points"), truth.ghost_points) << aligned.out;
  const ExeRun unaligned = run(scenario + " --classify-map " + moved_ply.string());
  ASSERT_EQ(unaligned.code, 0) << unaligned.err;
  EXPECT_LT(value(unaligned.out, "static_points"), truth.static_points) << unaligned.out;  // mostly off the world
  EXPECT_EQ(run(scenario + " --classify-map " + moved_ply.string() + " --map-trajectory " + temp_file("none.tum").string()).code, 4);
  EXPECT_EQ(run(scenario + " --out x --map-trajectory " + estimate.string()).code, 2);
  fs::remove(moved_ply);
  fs::remove(estimate);
  // Without traffic nothing is a ghost; a wider tolerance takes more points as static.
  const ExeRun off = run(scenario + " --traffic off --classify-map " + ply.string());
  ASSERT_EQ(off.code, 0) << off.err;
  EXPECT_EQ(value(off.out, "ghost_points"), 0u);
  EXPECT_EQ(value(off.out, "other_points"), truth.other_points + truth.ghost_points);
  const ExeRun wide = run(scenario + " --classify-map " + ply.string() + " --classify-tolerance 2");
  ASSERT_EQ(wide.code, 0) << wide.err;
  EXPECT_GT(value(wide.out, "static_points"), truth.static_points);
  // An unreadable map exits 4 naming the problem; a bad tolerance is a usage error.
  write_bytes(pcd, pcd_header(points.size() + 1), flat(points));
  const ExeRun truncated = run(scenario + " --classify-map " + pcd.string());
  EXPECT_EQ(truncated.code, 4);
  EXPECT_NE(truncated.err.find("truncated"), std::string::npos) << truncated.err;
  EXPECT_EQ(run(scenario + " --classify-map " + temp_file("missing.ply").string()).code, 4);
  EXPECT_EQ(run(scenario + " --classify-map " + ply.string() + " --classify-tolerance 0").code, 2);
  EXPECT_EQ(run(scenario + " --classify-tolerance 0.5 --out x").code, 2);
  fs::remove(ply);
  fs::remove(pcd);
}

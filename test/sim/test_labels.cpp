// The files of an urban run: point_labels.bin matches the recording scan by scan (end time and
// point count), moving_objects.csv lists the movers, identical arguments give identical bytes, and
// --traffic off gives the same ground truth, IMU and static points with every label 0.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "fuse/io/sensor_source.hpp"
#include "fuse/io/time_ns.hpp"
#include "fuse/sim/point_labels.hpp"

using namespace fuse::sim;
namespace fs = std::filesystem;

namespace {

fs::path simulate(const std::string& name, const std::string& args) {
  const fs::path dir = fs::temp_directory_path() / ("fuse_sim_labels_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string cmd = std::string(FUSE_SIM_EXE) + " " + args + " --out " + dir.string() + " >/dev/null 2>&1";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  return dir;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct Recording {
  std::vector<fuse::ImuSample> imu;
  std::vector<fuse::LidarScan> scans;
};

Recording read(const std::string& path) {
  Recording r;
  auto source = fuse::io::open_sensor_source(path);
  fuse::io::SensorEvent e;
  while (source->next(e)) {
    if (e.kind == fuse::io::SensorEvent::Kind::kImu)
      r.imu.push_back(e.imu);
    else
      r.scans.push_back(e.scan);
  }
  return r;
}

}  // namespace

TEST(SimLabels, LabelFileMatchesTheRecordingAndTrafficOffKeepsTheRest) {
  const std::string args = "--scenario urban --seed 7 --duration 1.5";
  const fs::path on = simulate("on", args), again = simulate("again", args),
                 off = simulate("off", args + " --traffic off"), seqdir = simulate("seqdir", args + " --format seqdir");
  for (const char* f : {"recording.mcap", "groundtruth.tum", "scenario.yaml", "point_labels.bin", "moving_objects.csv"})
    EXPECT_EQ(slurp(on / f), slurp(again / f)) << f << " differs between identical runs";

  // The labels, scan by scan, against the recording (MCAP and sequence directory).
  const std::vector<ScanLabels> labels = read_point_labels((on / "point_labels.bin").string());
  ASSERT_EQ(labels.size(), 15u);
  for (const std::string& path : {(on / "recording.mcap").string(), seqdir.string()}) {
    const Recording rec = read(path);
    ASSERT_EQ(rec.scans.size(), labels.size()) << path;
    for (std::size_t k = 0; k < labels.size(); ++k) {
      EXPECT_EQ(labels[k].t_end_ns, fuse::io::seconds_to_ns(rec.scans[k].t_end)) << path << " scan " << k;
      ASSERT_EQ(labels[k].labels.size(), rec.scans[k].points.size()) << path << " scan " << k;
    }
  }
  EXPECT_EQ(slurp(on / "point_labels.bin"), slurp(seqdir / "point_labels.bin"));
  std::size_t moving = 0;
  for (const ScanLabels& s : labels)
    moving += static_cast<std::size_t>(std::count(s.labels.begin(), s.labels.end(), 1));
  EXPECT_GT(moving, 100u);
  const std::string yaml = slurp(on / "scenario.yaml");
  EXPECT_NE(yaml.find("moving_points_total: " + std::to_string(moving)), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("engine:"), std::string::npos) << "the vibration is recorded";

  // moving_objects.csv: a header and one line per mover (120 cars, 150 pedestrians).
  std::istringstream csv(slurp(on / "moving_objects.csv"));
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "id,kind,length_m,width_m,height_m,speed_mps,t0_s,offset_m,loop_length_m,loop");
  std::map<std::string, int> kinds;
  while (std::getline(csv, line))
    ++kinds[line.substr(line.find(',') + 1, line.find(',', line.find(',') + 1) - line.find(',') - 1)];
  EXPECT_EQ(kinds["car"], 120);
  EXPECT_EQ(kinds["pedestrian"], 150);

  // --traffic off: the same truth and IMU (vibration included), every label 0, no movers listed,
  // and every static point of the run with traffic in the run without it.
  EXPECT_EQ(slurp(on / "groundtruth.tum"), slurp(off / "groundtruth.tum"));
  EXPECT_EQ(slurp(off / "moving_objects.csv"),
            "id,kind,length_m,width_m,height_m,speed_mps,t0_s,offset_m,loop_length_m,loop\n");
  const Recording a = read((on / "recording.mcap").string()), b = read((off / "recording.mcap").string());
  ASSERT_EQ(a.imu.size(), b.imu.size());
  for (std::size_t i = 0; i < a.imu.size(); ++i) {
    ASSERT_EQ(a.imu[i].accel, b.imu[i].accel);
    ASSERT_EQ(a.imu[i].gyro, b.imu[i].gyro);
  }
  const std::vector<ScanLabels> off_labels = read_point_labels((off / "point_labels.bin").string());
  ASSERT_EQ(off_labels.size(), labels.size());
  ASSERT_EQ(b.scans.size(), a.scans.size());
  for (std::size_t k = 0; k < labels.size(); ++k) {
    for (std::uint8_t l : off_labels[k].labels) ASSERT_EQ(l, 0);
    std::map<std::pair<float, std::uint16_t>, const fuse::LidarPoint*> statics;
    for (const fuse::LidarPoint& p : b.scans[k].points) statics[{p.t_rel, p.ring}] = &p;
    for (std::size_t i = 0; i < a.scans[k].points.size(); ++i) {
      if (labels[k].labels[i] == 1) continue;
      const fuse::LidarPoint& p = a.scans[k].points[i];
      const auto it = statics.find({p.t_rel, p.ring});
      ASSERT_NE(it, statics.end()) << "scan " << k << " point " << i;
      ASSERT_TRUE(p.x == it->second->x && p.y == it->second->y && p.z == it->second->z) << "scan " << k;
    }
  }
  for (const fs::path& d : {on, again, off, seqdir}) fs::remove_all(d);
}

TEST(SimLabels, OtherScenariosWriteAllStaticLabels) {
  const fs::path d = simulate("room", "--scenario room --seed 2 --duration 0.5");
  const std::vector<ScanLabels> labels = read_point_labels((d / "point_labels.bin").string());
  ASSERT_EQ(labels.size(), 5u);
  for (const ScanLabels& s : labels) {
    EXPECT_GT(s.labels.size(), 19000u);
    for (std::uint8_t l : s.labels) ASSERT_EQ(l, 0);
  }
  EXPECT_EQ(slurp(d / "scenario.yaml").find("vibration"), std::string::npos);
  // A damaged file is refused naming what is wrong.
  std::string bytes = slurp(d / "point_labels.bin");
  std::ofstream(d / "cut.bin", std::ios::binary) << bytes.substr(0, bytes.size() - 3);
  EXPECT_THROW(read_point_labels((d / "cut.bin").string()), std::runtime_error);
  bytes[0] = 'X';
  std::ofstream(d / "magic.bin", std::ios::binary) << bytes;
  EXPECT_THROW(read_point_labels((d / "magic.bin").string()), std::runtime_error);
  fs::remove_all(d);
}

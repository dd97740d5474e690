// Sequence directories: the reference sample (written by another simulator) read exactly, a
// byte-identical rewrite by SeqdirWriter, round trips and malformed inputs.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "fuse/io/seqdir.hpp"
#include "fuse/io/seqdir_source.hpp"
#include "fuse/io/sensor_source.hpp"
#include "test_util.hpp"

namespace fuse::io {
namespace {

namespace fs = std::filesystem;
using test::TempDir;

const std::string kSample = "seqdir-sample";

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void write_text(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

struct Read {
  std::vector<ImuSample> imu;
  std::vector<LidarScan> scans;
  std::vector<double> arrivals;
};

Read read_all(SensorSource& source) {
  Read out;
  SensorEvent e;
  while (source.next(e)) {
    out.arrivals.push_back(e.arrival_time());
    if (e.kind == SensorEvent::Kind::kImu) {
      out.imu.push_back(e.imu);
    } else {
      out.scans.push_back(e.scan);
    }
  }
  return out;
}

TEST(SeqdirSource, ReadsTheReferenceSample) {
  const std::string dir = test::shared_data(kSample);
  FUSE_REQUIRE_SHARED(dir);
  auto source = open_sensor_source(dir);
  ASSERT_TRUE(source->T_imu_lidar().has_value());
  EXPECT_TRUE(source->T_imu_lidar()->translation().isApprox(Eigen::Vector3d(-0.011, -0.02329, 0.04412), 1e-15));
  EXPECT_TRUE(source->T_imu_lidar()->linear().isIdentity());
  const Read r = read_all(*source);
  ASSERT_EQ(r.scans.size(), 80u);
  EXPECT_EQ(r.imu.size(), 1621u);
  EXPECT_TRUE(source->stats().rejected.empty());
  EXPECT_TRUE(std::is_sorted(r.arrivals.begin(), r.arrivals.end()));
  EXPECT_DOUBLE_EQ(r.imu.front().t, 1000.0);    // integer ns timestamps
  EXPECT_DOUBLE_EQ(r.imu[1].t, 1000.005);
  EXPECT_NEAR(r.imu.front().accel.z(), 9.86070783, 1e-12);
  for (const auto& s : r.scans) {
    ASSERT_EQ(s.points.size(), 20000u);
    EXPECT_NEAR(s.t_end - s.t_start, 0.1, 1e-9);
    for (const auto& p : s.points) {
      ASSERT_GE(p.t_rel, 0.f);
      ASSERT_LE(p.t_rel, 0.1f);
      ASSERT_LE(p.ring, 3);
    }
  }
  EXPECT_DOUBLE_EQ(r.scans.front().t_start, 1000.0);
  EXPECT_DOUBLE_EQ(r.scans.back().t_end, 1008.0);
}

// Reading the sample and writing it again gives the same bytes: the writer follows the format
// of the reference files exactly (headers, number formats, raw layout, calib.yaml).
TEST(SeqdirWriter, RewritesTheReferenceSampleByteForByte) {
  const std::string dir = test::shared_data(kSample);
  FUSE_REQUIRE_SHARED(dir);
  TempDir tmp;
  const std::string out = tmp.file("copy");
  SeqdirSource source(dir);
  {
    SeqdirWriter w(out, *source.T_imu_lidar());
    SensorEvent e;
    while (source.next(e)) {
      if (e.kind == SensorEvent::Kind::kImu) {
        w.write(e.imu);
      } else {
        w.write(e.scan);
      }
    }
    w.close();
  }
  for (const char* f : {"scans.csv", "imu.csv", "calib.yaml"}) {
    EXPECT_EQ(read_text(out + "/" + f), read_text(dir + "/" + f)) << f;
  }
  for (const char* f : {"raw/000000.bin", "raw/000041.bin", "raw/000079.bin"}) {
    EXPECT_EQ(test::read_bytes(out + "/" + f), test::read_bytes(dir + "/" + f)) << f;
  }
}

TEST(SeqdirWriter, RoundTripWithGroundTruth) {
  TempDir tmp;
  const std::string dir = tmp.file("seq");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.1, 0.2, -0.3);
  std::vector<ImuSample> imu;
  std::vector<LidarScan> scans;
  std::vector<StampedPose> gt;
  {
    SeqdirWriter w(dir, T);
    for (int i = 0; i < 50; ++i) {
      ImuSample s;
      s.t = 5.0 + 0.01 * i;
      s.gyro = Eigen::Vector3d(0.123456789, -1e-5 * i, 2.0);
      s.accel = Eigen::Vector3d(0.0, 0.5, 9.80665);
      imu.push_back(s);
      w.write(s);
      if (i % 10 == 9) {
        LidarScan scan;
        scan.t_start = s.t - 0.1;
        scan.t_end = s.t;
        scan.points = {{1.f, 2.f, 3.f, 4.f, 0.05f, 2}, {-1.f, 0.5f, 0.f, 0.f, 0.1f, 0}};
        scans.push_back(scan);
        w.write(scan);
        StampedPose p;
        p.t = scan.t_end;
        p.p = Eigen::Vector3d(i, 0.5, 0.25);
        gt.push_back(p);
      }
    }
    w.write_groundtruth(gt);
    w.close();
  }
  SeqdirSource source(dir);
  EXPECT_TRUE(source.T_imu_lidar()->isApprox(T, 1e-15));
  const Read r = read_all(source);
  ASSERT_EQ(r.imu.size(), imu.size());
  ASSERT_EQ(r.scans.size(), scans.size());
  for (std::size_t i = 0; i < imu.size(); ++i) {
    EXPECT_NEAR(r.imu[i].t, imu[i].t, 1e-12);
    EXPECT_TRUE(r.imu[i].gyro.isApprox(imu[i].gyro, 1e-8));
    EXPECT_TRUE(r.imu[i].accel.isApprox(imu[i].accel, 1e-8));
  }
  for (std::size_t i = 0; i < scans.size(); ++i) {
    EXPECT_EQ(r.scans[i].sequence, i);
    EXPECT_NEAR(r.scans[i].t_end, scans[i].t_end, 1e-9);
    ASSERT_EQ(r.scans[i].points.size(), 2u);
    EXPECT_EQ(r.scans[i].points[0].ring, 2);
    EXPECT_EQ(r.scans[i].points[1].y, 0.5f);
  }
  // Scans arrive after the IMU sample at their end time.
  EXPECT_TRUE(std::is_sorted(r.arrivals.begin(), r.arrivals.end()));
  const std::string gt_text = read_text(dir + "/gt_tum.txt");
  EXPECT_EQ(gt_text.substr(0, gt_text.find('\n')),
            "5.090000000 9.000000000 0.500000000 0.250000000 0.000000000 0.000000000 0.000000000 1.000000000");
}

/// A small valid sequence directory to break in one place per test.
std::string small_seqdir(const TempDir& tmp) {
  const std::string dir = tmp.file("small");
  SeqdirWriter w(dir, Eigen::Isometry3d::Identity());
  for (int i = 0; i < 30; ++i) {
    ImuSample s;
    s.t = 1.0 + 0.01 * i;
    s.accel.z() = 9.8;
    w.write(s);
    if (i % 10 == 9) {
      LidarScan scan;
      scan.t_start = s.t - 0.1;
      scan.t_end = s.t;
      scan.points.resize(5);
      w.write(scan);
    }
  }
  w.close();
  return dir;
}

void expect_input_error(const std::string& dir, const std::string& must_mention) {
  try {
    auto source = open_sensor_source(dir);
    read_all(*source);
    ADD_FAILURE() << "no InputError, expected one mentioning '" << must_mention << "'";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(must_mention), std::string::npos) << e.what();
  }
}

void replace_line(const std::string& file, std::size_t line_no, const std::string& text) {
  std::istringstream in(read_text(file));
  std::string out, line;
  for (std::size_t n = 1; std::getline(in, line); ++n) out += (n == line_no ? text : line) + "\n";
  write_text(file, out);
}

TEST(SeqdirSource, MalformedFilesRaiseInputErrorNamingFileAndLine) {
  {
    TempDir tmp;
    const auto dir = small_seqdir(tmp);
    replace_line(dir + "/scans.csv", 1, "index,start,end");
    expect_input_error(dir, "scans.csv line 1");
  }
  {
    TempDir tmp;
    const auto dir = small_seqdir(tmp);
    replace_line(dir + "/imu.csv", 1, "t,gx,gy,gz,ax,ay,az");
    expect_input_error(dir, "imu.csv line 1");
  }
  {
    TempDir tmp;
    const auto dir = small_seqdir(tmp);
    replace_line(dir + "/imu.csv", 5, "1040000000,0,0,0,0,0");
    expect_input_error(dir, "imu.csv line 5: 6 columns");
  }
  {
    TempDir tmp;
    const auto dir = small_seqdir(tmp);
    replace_line(dir + "/imu.csv", 3, "1020000000,0,abc,0,0,0,9.8");
    expect_input_error(dir, "imu.csv line 3: gyro_y 'abc'");
  }
  {
    TempDir tmp;
    const auto dir = small_seqdir(tmp);
    replace_line(dir + "/scans.csv", 3, "x1,1.1,1.2");
    expect_input_error(dir, "scans.csv line 3: idx");
  }
  {
    TempDir tmp;
    const auto dir = small_seqdir(tmp);
    fs::resize_file(dir + "/raw/000001.bin", 5 * 24 - 3);
    expect_input_error(dir, "000001.bin has 117 bytes");
  }
  {
    TempDir tmp;
    const auto dir = small_seqdir(tmp);
    fs::remove(dir + "/raw/000002.bin");
    expect_input_error(dir, "000002.bin");
  }
  {
    TempDir tmp;
    const auto dir = small_seqdir(tmp);
    write_text(dir + "/calib.yaml", "T_imu_lidar:\n  translation: [1, 2]\n  rotation_xyzw: [0, 0, 0, 1]\n");
    expect_input_error(dir, "translation");
  }
  {
    TempDir tmp;
    const auto dir = small_seqdir(tmp);
    std::ofstream(dir + "/raw/000000.bin", std::ios::binary | std::ios::app)
        .write("\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\0\x80\xbf", 24);  // ring -1
    expect_input_error(dir, "ring");
  }
  TempDir tmp;
  expect_input_error(tmp.file("nothing_here"), "no such file");
}

TEST(SeqdirSource, BadSamplesAreCounted) {
  TempDir tmp;
  const auto dir = small_seqdir(tmp);
  replace_line(dir + "/imu.csv", 4, "1.020000000,nan,0,0,0,0,9.8");     // NaN value
  replace_line(dir + "/imu.csv", 6, "1.000000000,0,0,0,0,0,9.8");       // time going backwards
  replace_line(dir + "/scans.csv", 3, "1,1.190000000,1.180000000");     // ends before it starts
  {
    std::ofstream raw(dir + "/raw/000002.bin", std::ios::binary | std::ios::trunc);
    const float p[6] = {std::nanf(""), 0.f, 0.f, 0.f, 0.f, 0.f};
    raw.write(reinterpret_cast<const char*>(p), sizeof p);
  }
  auto source = open_sensor_source(dir);
  const Read r = read_all(*source);
  EXPECT_EQ(r.imu.size(), 28u);
  EXPECT_EQ(r.scans.size(), 2u);
  const auto& rej = source->stats().rejected;
  EXPECT_EQ(rej.at(reason::kNanImu), 1u);
  EXPECT_EQ(rej.at(reason::kImuOutOfOrder), 1u);
  EXPECT_EQ(rej.at(reason::kScanEndBeforeStart), 1u);
  EXPECT_EQ(rej.at(reason::kNanPoints), 1u);
  EXPECT_EQ(rej.at(reason::kEmptyScan), 1u);  // the scan whose only point was NaN
}

TEST(SeqdirSource, SecondsTimestampsAreAccepted) {
  TempDir tmp;
  const auto dir = small_seqdir(tmp);
  replace_line(dir + "/imu.csv", 2, "1.000000000,0,0,0,0,0,9.8");
  auto source = open_sensor_source(dir);
  const Read r = read_all(*source);
  EXPECT_DOUBLE_EQ(r.imu.front().t, 1.0);
  EXPECT_EQ(r.imu.size(), 30u);
}

}  // namespace
}  // namespace fuse::io

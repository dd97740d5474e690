// fuse-import (the tool, run as a process) on bags written by independent implementations
// (interop/write_test_bags.mjs: @foxglove/rosmsg-serialization, @foxglove/rosmsg2-serialization,
// @mcap/core, sql.js; ROS 1 containers checked with @foxglove/rosbag): the recording read back
// through io::open_sensor_source matches the known contents in expected.json field by field.
// Run by ctest after the npm fixtures; a missing bag directory is a failure, never a skip.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "fuse/io/sensor_source.hpp"

namespace {

namespace fs = std::filesystem;

const fs::path kDir = ROSBAG_INTEROP_DIR;

const YAML::Node& expected() {
  static const YAML::Node root = [] {
    const fs::path p = kDir / "expected.json";
    if (!fs::exists(p)) return YAML::Node();
    return YAML::LoadFile(p.string());  // JSON is YAML
  }();
  return root;
}

YAML::Node find_case(const std::string& name) {
  for (const auto& c : expected()["cases"]) {
    if (c["name"].as<std::string>() == name) return c;
  }
  return YAML::Node();
}

class InteropBag : public ::testing::TestWithParam<std::string> {};

TEST_P(InteropBag, ImportedRecordingMatchesTheKnownContents) {
  ASSERT_TRUE(expected()["cases"]) << "no " << (kDir / "expected.json") << ": the bag-writing fixture did not run";
  const YAML::Node c = find_case(GetParam());
  ASSERT_TRUE(c) << GetParam() << " missing from expected.json";

  const fs::path out = kDir / (GetParam() + ".imported.mcap");
  const fs::path log = kDir / (GetParam() + ".import.txt");
  std::string cmd = std::string("'") + FUSE_IMPORT_BIN + "'";
  for (const auto& a : c["args"]) cmd += " '" + a.as<std::string>() + "'";
  cmd += " --out '" + out.string() + "' > '" + log.string() + "' 2>&1";
  const int rc = std::system(cmd.c_str());
  std::ifstream lf(log);
  std::stringstream text;
  text << lf.rdbuf();
  ASSERT_EQ(rc, 0) << cmd << "\n" << text.str();
  EXPECT_NE(text.str().find("skipped: malformed_lidar_message: " + std::to_string(c["malformed_lidar"].as<int>())),
            std::string::npos) << text.str();
  EXPECT_NE(text.str().find("other topics: " + std::to_string(c["other_topic_messages"].as<int>()) + " messages"),
            std::string::npos) << text.str();

  auto source = fuse::io::open_sensor_source(out.string());
  if (c["extrinsic"].IsSequence()) {
    const YAML::Node x = c["extrinsic"];
    ASSERT_TRUE(source->T_imu_lidar()) << "no calibration record";
    const Eigen::Isometry3d T = *source->T_imu_lidar();
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(T.translation()[k], x[k].as<double>(), 1e-12);
    const Eigen::Quaterniond q(T.linear());
    EXPECT_NEAR(std::abs(q.coeffs().dot(Eigen::Vector4d(x[3].as<double>(), x[4].as<double>(), x[5].as<double>(),
                                                         x[6].as<double>()))), 1.0, 1e-9);
  } else {
    EXPECT_FALSE(source->T_imu_lidar());
  }
  const YAML::Node imu = c["imu"], scans = c["scans"];
  std::size_t ni = 0, ns = 0;
  fuse::io::SensorEvent ev;
  while (source->next(ev)) {
    if (ev.kind == fuse::io::SensorEvent::Kind::kImu) {
      ASSERT_LT(ni, imu.size());
      const YAML::Node e = imu[ni++];
      EXPECT_NEAR(ev.imu.t, e[0].as<double>(), 1e-6);
      for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(ev.imu.gyro[k], e[1 + k].as<double>(), 1e-12);
        EXPECT_NEAR(ev.imu.accel[k], e[4 + k].as<double>(), 1e-12);
      }
    } else {
      ASSERT_LT(ns, scans.size());
      const YAML::Node e = scans[ns++];
      EXPECT_NEAR(ev.scan.t_start, e["t_start"].as<double>(), 1e-6);
      EXPECT_NEAR(ev.scan.t_end, e["t_end"].as<double>(), 1e-6);
      const YAML::Node pts = e["points"];
      ASSERT_EQ(ev.scan.points.size(), pts.size()) << "scan " << ns - 1;
      for (std::size_t i = 0; i < pts.size(); ++i) {
        const auto& p = ev.scan.points[i];
        EXPECT_EQ(p.x, pts[i][0].as<float>());
        EXPECT_EQ(p.y, pts[i][1].as<float>());
        EXPECT_EQ(p.z, pts[i][2].as<float>());
        EXPECT_EQ(p.intensity, pts[i][3].as<float>());
        EXPECT_EQ(p.ring, pts[i][4].as<int>());
        EXPECT_NEAR(p.t_rel, pts[i][5].as<double>(), 1e-6) << "scan " << ns - 1 << " point " << i;
      }
    }
  }
  EXPECT_EQ(ni, imu.size());
  EXPECT_EQ(ns, scans.size());
}

INSTANTIATE_TEST_SUITE_P(Bags, InteropBag,
                         ::testing::Values("ros1_ouster_t", "ros1_velodyne_time_bz2", "ros1_livox_custom_lz4_g",
                                           "rosbag2_mcap_hesai_timestamp", "rosbag2_sqlite_livox2_offset_time",
                                           "rosbag2_sqlite_livox2_custom"),
                         [](const auto& info) { return info.param; });

}  // namespace

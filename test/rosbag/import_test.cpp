// fuse-import's conversion on ROS 1 bags with known contents (IMU at 200 Hz, PointCloud2 with a
// `t` field or Livox CustomMsg at 10 Hz, other topics, a malformed message): the recording read
// back through io::open_sensor_source has every sample, field by field; topic choice errors.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fuse/io/recording.hpp"
#include "fuse/io/sensor_source.hpp"
#include "arguments.hpp"
#include "importer.hpp"
#include "message_encoder.hpp"
#include "ros1_bag_writer.hpp"
#include "../cli_capture.hpp"

namespace fuse::import {
namespace {

using rosbag::Serialization;
constexpr std::uint64_t kT0 = 1600000000000000000ull;  // ns

std::vector<std::uint8_t> imu_msg(std::uint64_t stamp, int i) {
  rosbag::test::Encoder e(Serialization::kRos1);
  e.header(stamp, "imu");
  for (double v : {0.0, 0.0, 0.0, 1.0}) e.put(v);
  for (int k = 0; k < 9; ++k) e.put(0.0);
  for (double v : {0.001 * i, -0.002 * i, 0.5}) e.put(v);
  for (int k = 0; k < 9; ++k) e.put(0.0);
  for (double v : {0.1, 0.2, 9.8 + 0.001 * i}) e.put(v);
  for (int k = 0; k < 9; ++k) e.put(0.0);
  return e.buf;
}

/// `n` points, x = scan index + point index / 1000, `t` = 100 us * point index.
std::vector<std::uint8_t> cloud_msg(std::uint64_t stamp, int scan, int n) {
  rosbag::test::Encoder e(Serialization::kRos1);
  e.header(stamp, "lidar");
  e.put<std::uint32_t>(1);
  e.put<std::uint32_t>(static_cast<std::uint32_t>(n));
  const std::vector<std::pair<std::string, std::pair<std::uint32_t, std::uint8_t>>> fields = {
      {"x", {0, 7}}, {"y", {4, 7}}, {"z", {8, 7}}, {"intensity", {12, 7}}, {"t", {16, 6}}, {"ring", {20, 4}}};
  e.put<std::uint32_t>(static_cast<std::uint32_t>(fields.size()));
  for (const auto& [name, f] : fields) {
    e.str(name);
    e.put<std::uint32_t>(f.first);
    e.put<std::uint8_t>(f.second);
    e.put<std::uint32_t>(1);
  }
  e.put<std::uint8_t>(0);
  e.put<std::uint32_t>(24);
  e.put<std::uint32_t>(24u * static_cast<std::uint32_t>(n));
  e.put<std::uint32_t>(24u * static_cast<std::uint32_t>(n));
  for (int i = 0; i < n; ++i) {
    e.put<float>(static_cast<float>(scan) + static_cast<float>(i) / 1000.f);
    e.put<float>(1.f);
    e.put<float>(2.f);
    e.put<float>(static_cast<float>(i % 256));
    e.put<std::uint32_t>(100000u * static_cast<std::uint32_t>(i));
    e.put<std::uint16_t>(static_cast<std::uint16_t>(i % 16));
    e.put<std::uint16_t>(0);
  }
  e.put<std::uint8_t>(1);
  return e.buf;
}

struct Bag {
  std::string path;
  std::vector<rosbag::test::WriterConnection> conns;
  std::vector<rosbag::test::WriterMessage> msgs;
  void write(const std::string& name, const std::string& compression = "lz4") {
    std::stable_sort(msgs.begin(), msgs.end(), [](const auto& a, const auto& b) { return a.time_ns < b.time_ns; });
    path = ::testing::TempDir() + "/" + name;
    rosbag::test::write_file(path, rosbag::test::write_bag(conns, msgs, compression, 50));
  }
};

/// 2 s of IMU at 200 Hz on /imu, 20 scans of 500 points at 10 Hz on /points, a /tf topic, and
/// one truncated IMU message.
Bag synthetic_bag() {
  Bag b;
  const std::string md5(32, 'a');
  b.conns = {{0, "/imu", "sensor_msgs/Imu", md5, ""},
             {1, "/points", "sensor_msgs/PointCloud2", md5, ""},
             {2, "/tf", "tf2_msgs/TFMessage", md5, ""}};
  for (int i = 0; i < 400; ++i) {
    const std::uint64_t t = kT0 + 5000000ull * i;
    b.msgs.push_back({0, t + 1000, imu_msg(t, i)});
  }
  auto bad = imu_msg(kT0 + 5000000ull * 400, 400);
  bad.resize(bad.size() - 5);
  b.msgs.push_back({0, kT0 + 5000000ull * 400 + 1000, bad});
  for (int s = 0; s < 20; ++s) {
    const std::uint64_t t = kT0 + 100000000ull * s;
    b.msgs.push_back({1, t + 100000000ull, cloud_msg(t, s, 500)});  // received at the scan's end
    b.msgs.push_back({2, t, {0, 0, 0, 0}});
  }
  return b;
}

TEST(Import, SyntheticRos1BagFieldByField) {
  Bag bag = synthetic_bag();
  bag.write("import_synthetic.bag");
  auto reader = rosbag::open_bag(bag.path);
  const TopicChoice c = choose_topics(*reader, {});
  EXPECT_EQ(reader->topics()[c.imu].name, "/imu");
  EXPECT_EQ(reader->topics()[c.lidar].name, "/points");
  EXPECT_EQ(expected_messages(*reader, c), std::optional<std::uint64_t>(401u + 20u));  // the progress line's total
  const std::string out = ::testing::TempDir() + "/import_synthetic.mcap";
  ImportSummary s;
  {
    io::RecordingWriter writer(out);
    s = import_bag(*reader, c, {}, writer);
    writer.close();
  }
  EXPECT_TRUE(s.error.empty()) << s.error;
  EXPECT_EQ(s.imu_messages, 401u);
  EXPECT_EQ(s.imu_written, 400u);
  EXPECT_EQ(s.skipped.at(skip::kMalformedImu), 1u);
  EXPECT_EQ(s.scans_written, 20u);
  EXPECT_EQ(s.points.kept, 20u * 500u);
  EXPECT_EQ(s.other_topic_messages, 20u);

  auto source = io::open_sensor_source(out);
  io::SensorEvent ev;
  int imu = 0, scans = 0;
  while (source->next(ev)) {
    if (ev.kind == io::SensorEvent::Kind::kImu) {
      EXPECT_NEAR(ev.imu.t, 1600000000.0 + 0.005 * imu, 1e-6);
      EXPECT_DOUBLE_EQ(ev.imu.gyro.x(), 0.001 * imu);
      EXPECT_DOUBLE_EQ(ev.imu.gyro.y(), -0.002 * imu);
      EXPECT_DOUBLE_EQ(ev.imu.accel.z(), 9.8 + 0.001 * imu);
      ++imu;
    } else {
      const auto& scan = ev.scan;
      EXPECT_NEAR(scan.t_start, 1600000000.0 + 0.1 * scans, 1e-6);
      EXPECT_NEAR(scan.t_end - scan.t_start, 499 * 1e-4, 1e-6);
      EXPECT_EQ(scan.points.size(), 500u);
      for (std::size_t i = 0; i < scan.points.size(); i += 97) {
        EXPECT_FLOAT_EQ(scan.points[i].x, static_cast<float>(scans) + static_cast<float>(i) / 1000.f);
        EXPECT_FLOAT_EQ(scan.points[i].z, 2.f);
        EXPECT_FLOAT_EQ(scan.points[i].intensity, static_cast<float>(i % 256));
        EXPECT_EQ(scan.points[i].ring, i % 16);
        EXPECT_NEAR(scan.points[i].t_rel, 1e-4 * static_cast<double>(i), 1e-6);
      }
      ++scans;
    }
  }
  EXPECT_EQ(imu, 400);
  EXPECT_EQ(scans, 20);
  std::filesystem::remove(out);
  std::filesystem::remove(bag.path);
}

/// A bag of two topics with the counts it declares (0: none), for expected_messages.
class DeclaredCounts final : public rosbag::BagReader {
 public:
  DeclaredCounts(std::uint64_t imu, std::uint64_t lidar)
      : topics_{{"/imu", "sensor_msgs/Imu", Serialization::kRos1, imu},
                {"/points", "sensor_msgs/PointCloud2", Serialization::kRos1, lidar}} {}
  const std::vector<rosbag::BagTopic>& topics() const override { return topics_; }
  std::uint64_t start_time_ns() const override { return 0; }
  std::uint64_t end_time_ns() const override { return 0; }
  void start(const std::vector<std::string>&) override {}
  bool next(rosbag::BagMessage&) override { return false; }
  std::string describe() const override { return "declared counts"; }

 private:
  std::vector<rosbag::BagTopic> topics_;
};

TEST(Import, ProgressTotalOnlyWhenTheBagDeclaresBothCounts) {
  const TopicChoice c{0, 1, LidarKind::kPointCloud2};
  EXPECT_EQ(expected_messages(DeclaredCounts(400, 20), c), std::optional<std::uint64_t>(420u));
  EXPECT_FALSE(expected_messages(DeclaredCounts(0, 20), c));  // then the line has no percentage
  EXPECT_FALSE(expected_messages(DeclaredCounts(400, 0), c));
}

TEST(Import, TopicChoiceErrors) {
  Bag bag = synthetic_bag();
  bag.conns.push_back({3, "/imu2", "sensor_msgs/Imu", std::string(32, 'a'), ""});
  bag.msgs.push_back({3, kT0, imu_msg(kT0, 0)});
  bag.write("import_two_imus.bag", "bz2");
  auto reader = rosbag::open_bag(bag.path);
  auto error_of = [&](const ImportConfig& cfg) {
    try {
      choose_topics(*reader, cfg);
      return std::string();
    } catch (const TopicError& e) {
      return std::string(e.what());
    }
  };
  EXPECT_NE(error_of({}).find("several sensor_msgs/Imu topics ( /imu /imu2 ); choose one with --imu-topic"),
            std::string::npos) << error_of({});
  ImportConfig cfg;
  cfg.imu_topic = "/imu2";
  EXPECT_EQ(error_of(cfg), "");
  cfg.imu_topic = "/tf";
  EXPECT_NE(error_of(cfg).find("--imu-topic /tf has type tf2_msgs/TFMessage"), std::string::npos);
  cfg.imu_topic = "/nope";
  EXPECT_NE(error_of(cfg).find("no topic /nope"), std::string::npos);
  cfg.imu_topic = "/imu";
  cfg.lidar_topic = "/imu2";
  EXPECT_NE(error_of(cfg).find("--lidar-topic /imu2 has type sensor_msgs/Imu"), std::string::npos);
  std::filesystem::remove(bag.path);
}

TEST(Import, TypeNames) {
  EXPECT_TRUE(is_imu_type("sensor_msgs/msg/Imu"));
  EXPECT_TRUE(is_imu_type("sensor_msgs/Imu"));
  LidarKind k;
  EXPECT_TRUE(is_lidar_type("livox_ros_driver2/msg/CustomMsg", &k));
  EXPECT_EQ(k, LidarKind::kLivoxCustom);
  EXPECT_TRUE(is_lidar_type("sensor_msgs/msg/PointCloud2", &k));
  EXPECT_EQ(k, LidarKind::kPointCloud2);
  EXPECT_FALSE(is_lidar_type("sensor_msgs/LaserScan"));
}

}  // namespace
}  // namespace fuse::import

namespace fuse::import {
namespace {

/// parse_arguments on the command line "fuse-import ARGS...": its result and what it printed.
struct Parsed {
  std::optional<int> code;  ///< std::nullopt: the import would run
  Arguments arguments;
  std::string out, err;
};

Parsed parse(std::vector<std::string> args) {
  Parsed p;
  const fuse::test::CapturedCli c = fuse::test::run_cli_parser(
      "fuse-import", std::move(args), [&](int argc, char** argv) { return parse_arguments(argc, argv, p.arguments); });
  p.code = c.code;
  p.out = c.out;
  p.err = c.err;
  return p;
}

TEST(ImportArguments, ParsedAndCheckedBeforeAnythingIsRead) {
  const Parsed p = parse({"--input", "x.bag", "--out", "y.mcap", "--imu-topic", "/imu", "--lidar-topic=/points",
                          "--time-field", "time", "--imu-accel-unit", "g", "--extrinsic",
                          "0.1,0,-0.2,0,0,0.7071068,0.7071068"});
  ASSERT_FALSE(p.code) << p.err;
  const Arguments& a = p.arguments;
  EXPECT_EQ(a.input, "x.bag");
  EXPECT_EQ(a.out, "y.mcap");
  EXPECT_EQ(a.import.imu_topic, "/imu");
  EXPECT_EQ(a.import.lidar_topic, "/points");
  EXPECT_EQ(a.import.time_field, "time");
  EXPECT_DOUBLE_EQ(a.import.accel_scale, 9.80665);
  ASSERT_TRUE(a.T_imu_lidar);
  EXPECT_NEAR(a.T_imu_lidar->translation().z(), -0.2, 1e-12);
  EXPECT_NEAR((a.T_imu_lidar->linear() * Eigen::Vector3d::UnitX()).y(), 1.0, 1e-6);  // 90 deg about z
  // An extrinsic starting with a minus sign is a value, not an option.
  const Parsed minus = parse({"--input", "x", "--out", "y", "--extrinsic", "-0.5,0,0,0,0,0,1"});
  ASSERT_TRUE(minus.arguments.T_imu_lidar) << minus.err;
  EXPECT_NEAR(minus.arguments.T_imu_lidar->translation().x(), -0.5, 1e-12);
}

TEST(ImportArguments, Defaults) {
  const Parsed p = parse({"--input", "x", "--out", "y"});
  ASSERT_FALSE(p.code) << p.err;
  EXPECT_EQ(p.arguments.import.imu_topic, "");
  EXPECT_EQ(p.arguments.import.lidar_topic, "");
  EXPECT_EQ(p.arguments.import.time_field, "");
  EXPECT_DOUBLE_EQ(p.arguments.import.accel_scale, 1.0);
  EXPECT_FALSE(p.arguments.T_imu_lidar);
  EXPECT_DOUBLE_EQ(parse({"--input", "x", "--out", "y", "--imu-accel-unit", "mps2"}).arguments.import.accel_scale, 1.0);
}

TEST(ImportArguments, HelpAndVersionExitZeroOnStdout) {
  const Parsed help = parse({"--help"});
  EXPECT_EQ(help.code, 0);
  EXPECT_NE(help.out.find("Usage: fuse-import"), std::string::npos) << help.out;
  EXPECT_NE(help.out.find("--extrinsic"), std::string::npos) << help.out;
  const Parsed version = parse({"--version"});
  EXPECT_EQ(version.code, 0);
  EXPECT_EQ(version.out.rfind("fuse-import (FUSE-SLAM) ", 0), 0u) << version.out;
}

TEST(ImportArguments, BadArgumentsExitTwoNamingTheFlag) {
  // Each bad command line and what the message (on stderr) must contain.
  const std::vector<std::pair<std::vector<std::string>, std::string>> bad = {
      {{"--out", "y"}, "--input is required"},
      {{"--input", "x"}, "--out is required"},
      {{"--input", "x", "--out", "y", "--time-field", "stamp"}, "--time-field: 'stamp' is not t, time"},
      {{"--input", "x", "--out", "y", "--imu-accel-unit", "ft"}, "--imu-accel-unit: 'ft' is not g or mps2"},
      {{"--input", "x", "--out", "y", "--extrinsic", "1,2,3"}, "--extrinsic needs 7 comma-separated"},
      {{"--input", "x", "--out", "y", "--extrinsic", "0,0,0,0,0,0,2"}, "--extrinsic: the quaternion"},
      {{"--input", "x", "--out", "y", "--extrinsic", "0,0,a,0,0,0,1"}, "--extrinsic: 'a' is not a number"},
      {{"--input", "x", "--out", "y", "--extrinsic", "0,0,inf,0,0,0,1"}, "--extrinsic: values must be finite"},
      {{"--out", "y", "--input"}, "--input"},  // no value
      {{"--input", "x", "--out", "y", "--bogus"}, "unknown option --bogus"},
  };
  for (const auto& [args, message] : bad) {
    const Parsed p = parse(args);
    EXPECT_EQ(p.code, 2) << ::testing::PrintToString(args);  // fuse::cli::kExitUsage
    EXPECT_NE(p.err.find("fuse-import: " + message), std::string::npos) << ::testing::PrintToString(args) << "\n"
                                                                        << p.err;
  }
}

}  // namespace
}  // namespace fuse::import

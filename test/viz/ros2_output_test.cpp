// ROS 2 out (ros2.enabled): fuse-state, fuse-update and fuse-map replay the 20 s corridor in
// lockstep with ROS 2 output on; the test subscribes to the rt/ topics with the ROS 2 type names
// and ROS 2's QoS profiles (as a ROS 2 node would), keeps the raw samples, and has them decoded
// by an implementation that is not FUSE's: Foxglove's ROS 2 CDR reader with the Jazzy and Humble
// message definitions (ros2/decode_ros2.mjs), field by field against what FUSE published on its
// own topics for the same times (state/odometry, update/world_scan, map/status).
// DDS domain 0 belongs to this file.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

#include "fuse/io/sensor_source.hpp"
#include "fuse/launch/process.hpp"
#include "system_test_util.hpp"
#include "fuse/transport/msg_traits.hpp"
#include "fuse/transport/ros2.hpp"
#include "fuse/transport/transport.hpp"

namespace fuse {
namespace {

namespace fs = std::filesystem;
namespace ros2 = transport::ros2;
using namespace std::chrono_literals;
using launch::Process;
using namespace viz_test;

constexpr int kDomain = 0;
const std::string kCheckDir = FUSE_ROS2_CHECK_DIR;

std::string key(double t) { return std::to_string(std::llround(t * 1e6)); }
std::string num(double v) {
  std::ostringstream out;
  out.precision(17);
  out << v;
  return out.str();
}

/// width of a PointCloud2 sample: after the encapsulation, the stamp, the frame string (length,
/// bytes, aligned to 4) and the height.
std::uint32_t cloud_width(const transport::Bytes& b) {
  auto u32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | b.at(at + static_cast<std::size_t>(i));
    return v;
  };
  std::size_t at = 4 + 8;
  const std::uint32_t frame_length = u32(at);
  at += 4 + frame_length;
  at = 4 + ((at - 4 + 3) & ~std::size_t{3});
  return u32(at + 4);
}

struct Captured {
  std::mutex mutex;
  std::map<std::string, std::vector<transport::Bytes>> samples;  // by topic kind
  std::map<std::string, std::size_t> limits{{"odometry", 40}, {"tf", 20}, {"tf_static", 2},
                                            {"scan", 20}, {"diagnostics", 40}};
  transport::Bytes last_map;
  std::string odometry_json, scans_json;
  std::size_t odometry_n = 0, scans_n = 0;
  std::uint64_t map_points = 0;
};

TEST(Ros2Output, ARos2NodeDecodesWhatFusePublished) {
  if (!fs::exists(kRecording)) GTEST_SKIP() << "no recording at " << kRecording << " (the fuse_sim_data fixture)";
  ASSERT_TRUE(fs::exists(kCheckDir + "/node_modules/@foxglove/rosmsg2-serialization")) << "npm install did not run";
  const std::string dir = kOut + "/ros2_output";
  fs::remove_all(dir);
  fs::create_directories(dir + "/logs");
  fs::create_directories(dir + "/samples");

  Captured cap;
  transport::TransportConfig tc;
  tc.domain_id = kDomain;
  auto participant = transport::make_participant(tc, "ros2-test");
  // As a ROS 2 node subscribes: rt/ names, ROS 2 type names, ROS 2's QoS.
  std::vector<std::unique_ptr<transport::RawReader>> readers;
  auto ros_reader = [&](const std::string& kind, const std::string& topic, const char* type, transport::TopicQos qos) {
    readers.push_back(participant->create_reader(
        ros2::dds_topic(topic), ros2::type_support(type, std::size_t{256} << 20), qos,
        [&cap, kind](const std::uint8_t* data, std::size_t size) {
          std::lock_guard<std::mutex> lock(cap.mutex);
          if (kind == "map") {
            cap.last_map.assign(data, data + size);
            return;
          }
          auto& list = cap.samples[kind];
          if (list.size() < cap.limits[kind]) list.emplace_back(data, data + size);
        }));
  };
  transport::TopicQos tf_qos = ros2::default_qos();
  tf_qos.depth = 100;
  ros_reader("odometry", "/fuse/odometry", ros2::kOdometryType, ros2::sensor_data_qos());
  ros_reader("tf", "/tf", ros2::kTfMessageType, tf_qos);
  ros_reader("tf_static", "/tf_static", ros2::kTfMessageType, ros2::transient_local_qos());
  ros_reader("scan", "/fuse/cloud_registered", ros2::kPointCloud2Type, ros2::sensor_data_qos());
  ros_reader("map", "/fuse/map", ros2::kPointCloud2Type, ros2::transient_local_qos());
  ros_reader("diagnostics", "/diagnostics", ros2::kDiagnosticArrayType, ros2::default_qos());
  // What FUSE published on its own topics, the expected values.
  transport::Subscriber<fuse_msgs::StateEstimate> odometry(*participant, transport::topics::kOdometry,
                                                           [&cap](const fuse_msgs::StateEstimate& s) {
    const auto& p = s.pose().position();
    const auto& q = s.pose().orientation();
    const double speed = std::hypot(s.velocity().x(), s.velocity().y(), s.velocity().z());
    std::lock_guard<std::mutex> lock(cap.mutex);
    cap.odometry_json += std::string(cap.odometry_n++ ? "," : "") + "\"" + key(s.t()) + "\":{\"frame\":\"world\"," +
                         "\"child_frame\":\"imu\",\"position\":[" + num(p.x()) + "," + num(p.y()) + "," + num(p.z()) +
                         "],\"orientation\":[" + num(q.x()) + "," + num(q.y()) + "," + num(q.z()) + "," + num(q.w()) +
                         "],\"covariance_xx\":" + num(s.pose_covariance()[0]) + ",\"speed\":" + num(speed) + "}";
  });
  transport::Subscriber<fuse_msgs::WorldScan> scans(*participant, transport::topics::kWorldScan,
                                                    [&cap](const fuse_msgs::WorldScan& s) {
    double sx = 0, sy = 0, sz = 0;
    for (const auto& p : s.points()) {
      sx += p.x();
      sy += p.y();
      sz += p.z();
    }
    std::lock_guard<std::mutex> lock(cap.mutex);
    cap.scans_json += std::string(cap.scans_n++ ? "," : "") + "\"" + key(s.t()) + "\":{\"points\":" +
                      std::to_string(s.points().size()) + ",\"sum\":[" + num(sx) + "," + num(sy) + "," + num(sz) + "]}";
  });
  transport::Subscriber<fuse_msgs::MapStatus> status(*participant, transport::topics::kMapStatus,
                                                     [&cap](const fuse_msgs::MapStatus& s) {
    std::lock_guard<std::mutex> lock(cap.mutex);
    cap.map_points = s.points();
  });

  auto args = [](const std::string& service, const std::vector<std::string>& more) {
    return service_argv(service, kDomain,
                        {"ingest.lockstep_timeout_s=1.5", "update.map_sync_timeout_s=3", "ros2.enabled=true",
                         "ros2.map_period_s=0.2"},
                        more);
  };
  std::map<std::string, Process> services;
  services.emplace("fuse-map", Process::spawn(args("fuse-map", {"--map-dir", dir + "/map"}), dir + "/logs/fuse-map.log"));
  services.emplace("fuse-state", Process::spawn(args("fuse-state", {"--calibration-from", kRecording}),
                                                dir + "/logs/fuse-state.log"));
  services.emplace("fuse-update", Process::spawn(args("fuse-update", {}), dir + "/logs/fuse-update.log"));
  // The scan writer is matched before the replay (fuse-update builds the cloud only for a matched reader).
  ASSERT_TRUE(wait_until([&] { return readers[3]->matched_writers() > 0; }, 60s)) << "no ROS 2 scan writer";
  Process ingest = Process::spawn(args("fuse-ingest", {"--input", kRecording, "--mode", "lockstep"}),
                                  dir + "/logs/fuse-ingest.log");
  const auto done = ingest.wait_for(240s);
  ASSERT_TRUE(done.has_value()) << "replay did not finish";
  EXPECT_EQ(done->code, 0);
  // The last map cloud has the map server's points; diagnostics came from all three.
  ASSERT_TRUE(wait_until([&] {
    std::lock_guard<std::mutex> lock(cap.mutex);
    return cap.map_points > 0 && !cap.last_map.empty() && cloud_width(cap.last_map) == cap.map_points &&
           cap.samples["diagnostics"].size() >= 9 && cap.samples["scan"].size() >= 5;
  }, 60s)) << "map server " << cap.map_points << " points";
  for (auto& [name, process] : services) {
    const auto t = process.terminate(10s);
    EXPECT_EQ(t.status.code, 0) << name;
  }
  readers.clear();

  const Eigen::Isometry3d T_imu_lidar = *io::open_sensor_source(kRecording)->T_imu_lidar();
  {
    std::lock_guard<std::mutex> lock(cap.mutex);
    for (const auto& [kind, list] : cap.samples) {
      for (std::size_t i = 0; i < list.size(); ++i) {
        std::ofstream(dir + "/samples/" + kind + "_" + std::to_string(100 + i) + ".cdr", std::ios::binary)
            .write(reinterpret_cast<const char*>(list[i].data()), static_cast<std::streamsize>(list[i].size()));
      }
    }
    std::ofstream(dir + "/samples/map_100.cdr", std::ios::binary)
        .write(reinterpret_cast<const char*>(cap.last_map.data()), static_cast<std::streamsize>(cap.last_map.size()));
    const Eigen::Vector3d t = T_imu_lidar.translation();
    std::ofstream(dir + "/samples/expected.json")
        << "{\"odometry\":{" << cap.odometry_json << "},\"scans\":{" << cap.scans_json << "},"
        << "\"tf\":{\"parent\":\"world\",\"child\":\"imu\"},"
        << "\"tf_static\":{\"parent\":\"imu\",\"child\":\"lidar\",\"translation\":[" << num(t.x()) << "," << num(t.y())
        << "," << num(t.z()) << "]},\"map_points\":" << cap.map_points << ",\"world_frame\":\"world\","
        << "\"services\":[\"fuse-state\",\"fuse-update\",\"fuse-map\"]}\n";
    for (const char* kind : {"odometry", "tf", "tf_static", "scan", "diagnostics"}) {
      EXPECT_FALSE(cap.samples[kind].empty()) << "nothing received on the ROS 2 " << kind << " topic";
    }
  }
  Process decode = Process::spawn({FUSE_NODE, kCheckDir + "/decode_ros2.mjs", dir + "/samples"}, dir + "/logs/decode.log");
  const auto decoded = decode.wait_for(120s);
  ASSERT_TRUE(decoded.has_value());
  EXPECT_EQ(decoded->code, 0) << read_file(dir + "/logs/decode.log");
  std::cout << read_file(dir + "/logs/decode.log");
}

}  // namespace
}  // namespace fuse

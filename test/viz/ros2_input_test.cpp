// ROS 2 in: a ROS 2 driver stand-in (ros2_sensor_publisher, a separate process) publishes the
// simulated 20 s corridor in real time as sensor_msgs/Imu with sensor_msgs/PointCloud2 (ouster_ros
// layout) or livox_ros_driver2/CustomMsg; fuse-ingest --ros2 reads them and the services estimate.
// The trajectory must be the plain replay's: the same services replaying the recording in real
// time with fuse-ingest --input (once, for both layouts). One difference is in the data itself: a
// ROS 2 cloud has no frame-end time, so a scan ends at its last point, 5 us before the frame end
// FUSE's recordings give; the very first scan then ends just before the IMU sample that completes
// static initialisation, after the sample before it (the sensor rested between the two: StateHistory), and
// is answered as the plain replay's is. So: a pose for every scan the plain replay has, at the same
// time (within 10 us), every position within 1 cm of the plain replay's (measured: 2.2 mm), and the
// same error against the simulator's truth (ATE within 1.1x + 2 mm of the plain replay's).
// The driver stand-in publishes reliably and starts once its writers see fuse-ingest's readers;
// fuse-ingest reads reliably here (--ros2-reliability reliable), so that the first IMU samples,
// sent before its own side of discovery completes, are delivered too, as they are to the plain
// replay: a best-effort reader loses them, and the estimate then starts a few samples later.
// DDS domain 0, shared with ros2_output_test (both RUN_SERIAL).
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include "fuse/eval/evaluate.hpp"
#include "fuse/eval/trajectory.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/launch/process.hpp"
#include "system_test_util.hpp"

namespace fuse {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using launch::Process;
using namespace viz_test;

constexpr int kDomain = 0;

/// The end time of the recording's last scan.
double last_scan_end() {
  auto source = io::open_sensor_source(kRecording);
  io::SensorEvent ev;
  double t = 0.0;
  while (source->next(ev)) {
    if (ev.kind == io::SensorEvent::Kind::kLidar) t = ev.scan.t_end;
  }
  return t;
}

/// Time of the last pose of a trajectory file (0 when empty).
double last_pose_t(const std::string& path) {
  std::ifstream f(path);
  double t = 0.0;
  for (std::string line; std::getline(f, line);) {
    if (!line.empty() && line[0] != '#') t = std::atof(line.c_str());
  }
  return t;
}

/// The services with one fuse-ingest (its own arguments), and `driver` beside it when given; ends
/// once the ingest's input is over (the replay's end, or the driver's) and the pose of the last
/// scan is written (or 60 s more passed). Returns the trajectory file.
std::string run_services(const std::string& dir, const std::vector<std::string>& ingest,
                         const std::vector<std::string>& driver) {
  fs::remove_all(dir);
  fs::create_directories(dir + "/logs");
  auto args = [](const std::string& service, const std::vector<std::string>& more) {
    return service_argv(service, kDomain, {"update.map_sync_timeout_s=3"}, more);
  };
  const std::string trajectory = dir + "/trajectory.tum";
  std::map<std::string, Process> services;
  services.emplace("fuse-map", Process::spawn(args("fuse-map", {"--map-dir", dir + "/map"}), dir + "/logs/fuse-map.log"));
  services.emplace("fuse-state", Process::spawn(args("fuse-state", {"--trajectory", trajectory, "--calibration-from",
                                                                    kRecording}),
                                                dir + "/logs/fuse-state.log"));
  services.emplace("fuse-update", Process::spawn(args("fuse-update", {}), dir + "/logs/fuse-update.log"));
  Process ingester = Process::spawn(args("fuse-ingest", ingest), dir + "/logs/fuse-ingest.log");
  if (!driver.empty()) {
    Process d = Process::spawn(driver, dir + "/logs/driver.log");
    const auto driven = d.wait_for(180s);
    EXPECT_TRUE(driven && driven->code == 0) << read_file(dir + "/logs/driver.log");
  } else {
    const auto replayed = ingester.wait_for(180s);
    EXPECT_TRUE(replayed && replayed->code == 0) << read_file(dir + "/logs/fuse-ingest.log");
  }
  // Every scan processed: the last scan's pose is written (deadline generous for a loaded machine).
  static const double last_t = last_scan_end();
  const auto end = std::chrono::steady_clock::now() + 60s;
  while (last_pose_t(trajectory) < last_t - 0.01 && std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_GE(last_pose_t(trajectory), last_t - 0.01) << "the last scan has no pose in " << trajectory;
  if (ingester.is_running()) {
    EXPECT_EQ(ingester.terminate(10s).status.code, 0) << read_file(dir + "/logs/fuse-ingest.log");
  }
  for (auto& [name, process] : services) {
    const auto t = process.terminate(10s);
    EXPECT_EQ(t.status.code, 0) << name << ": " << read_file(dir + "/logs/" + name + ".log").substr(0, 3000);
  }
  return trajectory;
}

class Ros2Input : public ::testing::TestWithParam<std::string> {
 protected:
  /// The plain replay, once for both layouts.
  static void SetUpTestSuite() {
    if (!fs::exists(kRecording)) return;
    plain_ = run_services(kOut + "/ros2_input_plain", {"--input", kRecording, "--mode", "realtime"}, {});
  }
  static inline std::string plain_;
};

TEST_P(Ros2Input, ADriversTopicsGiveThePlainReplaysTrajectory) {
  if (!fs::exists(kRecording)) GTEST_SKIP() << "no recording at " << kRecording << " (the fuse_sim_data fixture)";
  const std::string type = GetParam();
  const eval::Trajectory a = eval::read_tum(plain_);
  ASSERT_GT(a.size(), 100u) << "the plain replay";
  const std::string trajectory =
      run_services(kOut + "/ros2_input_" + type,
                   {"--ros2", "/sensor/imu,/sensor/points", "--ros2-lidar-type", type, "--ros2-reliability", "reliable"},
                   {FUSE_ROS2_PUBLISHER, std::to_string(kDomain), kRecording, "/sensor/imu", "/sensor/points", type});
  const eval::Trajectory b = eval::read_tum(trajectory);
  EXPECT_EQ(b.size(), a.size()) << "poses from ROS 2 input against the plain replay's";
  ASSERT_GT(a.size(), 100u);
  double worst = 0.0;
  std::size_t matched = 0;
  std::size_t j = 0;
  for (const StampedPose& p : b) {
    while (j + 1 < a.size() && std::abs(a[j + 1].t - p.t) <= std::abs(a[j].t - p.t)) ++j;
    if (std::abs(a[j].t - p.t) > 1e-5) continue;
    ++matched;
    worst = std::max(worst, (a[j].p - p.p).norm());
  }
  EXPECT_EQ(matched, b.size()) << "poses at the plain replay's times";
  EXPECT_LT(worst, 0.01) << "largest position difference to the plain replay";
  const eval::Trajectory truth = eval::read_tum(std::string(FUSE_TEST_DATA) + "/corridor20/groundtruth.tum");
  const double ate_plain = eval::evaluate(truth, a).ate.rmse, ate_ros2 = eval::evaluate(truth, b).ate.rmse;
  EXPECT_LE(ate_ros2, 1.1 * ate_plain + 0.002) << "ATE " << ate_ros2 << " m against the plain replay's " << ate_plain;
  std::cout << type << ": " << b.size() << " poses (plain " << a.size() << "), " << matched
            << " at the same times, largest difference " << worst << " m, ATE " << ate_ros2 << " m (plain " << ate_plain
            << " m)\n";
  const std::string ingest_log = read_file(kOut + "/ros2_input_" + type + "/logs/fuse-ingest.log");
  EXPECT_EQ(ingest_log.find("undecodable"), std::string::npos) << ingest_log.substr(0, 3000);
}

INSTANTIATE_TEST_SUITE_P(Layouts, Ros2Input, ::testing::Values("pointcloud2", "livox"));

}  // namespace
}  // namespace fuse

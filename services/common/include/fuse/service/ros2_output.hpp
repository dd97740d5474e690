// A service's ROS 2 output (ros2.enabled; docs/architecture.md, "ROS 2"): writers of ROS 2 types
// on ROS 2 topics (fuse/transport/ros2.hpp), each created only for what this service publishes.
//   fuse-state:  odometry (nav_msgs/Odometry, IMU rate, sensor-data QoS), /tf world -> imu,
//                /tf_static imu -> lidar (transient local)
//   fuse-update: the deskewed scan (sensor_msgs/PointCloud2, world frame, sensor-data QoS)
//   fuse-map:    the whole map (PointCloud2, transient local, at most every ros2.map_period_s)
//   every one:   its health as diagnostic_msgs/DiagnosticArray on /diagnostics
// A sample the DDS backend refuses is counted by topic (`ros2_write_failed_<output>`) and logged
// rate-limited; attach() puts those counters into the service's health and sends every heartbeat
// as diagnostics. Thread-safe.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "fuse/core/counters.hpp"
#include "fuse/service/system_config.hpp"
#include "fuse/transport/msg_traits.hpp"

namespace fuse::service {

class HealthReporter;

class Ros2Output {
 public:
  struct Outputs {
    bool odometry = false;  ///< odometry, /tf, /tf_static
    bool scan = false;
    bool map = false;
  };
  Ros2Output(transport::Participant& participant, const Ros2Config& config, Outputs outputs);

  /// Odometry and /tf from an odometry sample (twist in the IMU frame). Throws InvalidSample.
  void odometry(const fuse_msgs::StateEstimate& s);
  /// /tf_static: imu -> lidar (latched for late subscribers).
  void static_transform(const Eigen::Isometry3d& T_imu_lidar);
  /// Whether a ROS 2 subscriber of the scan is matched (the caller may skip building it).
  bool scan_wanted() const;
  void scan(double t, const std::vector<float>& xyz_world);
  void map(double t, const std::vector<float>& xyz_world);
  /// A heartbeat as one DiagnosticStatus (running OK, starting and stopping OK with their word,
  /// degraded WARN, anything else ERROR; the counters as key/values), stamped with the host's
  /// UTC time (a heartbeat has no sensor time).
  void diagnostics(const fuse_msgs::Health& h);
  /// Publishes `health`'s heartbeats as diagnostics and adds this output's counters to them.
  void attach(HealthReporter& health);
  /// Samples refused by the DDS backend, by output (odometry, tf, tf_static, scan, map, diagnostics).
  std::map<std::string, std::uint64_t> counters() const;

 private:
  /// Writes under the lock; a refused sample is counted (caller holds mutex_).
  void write(transport::RawWriter& writer, const transport::Bytes& sample, const char* output);

  Ros2Config config_;
  std::unique_ptr<transport::RawWriter> odometry_, tf_, tf_static_, scan_, map_, diagnostics_;
  mutable std::mutex mutex_;
  Counters counters_;  ///< mutex_
};

}  // namespace fuse::service

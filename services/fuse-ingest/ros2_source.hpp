// ROS 2 in: a live source reading a ROS 2 driver's topics on the same DDS domain, as a ROS 2 node
// would subscribe (rt/ topics, ROS 2 type names; fuse/transport/ros2.hpp):
//   IMU:   sensor_msgs/Imu
//   LiDAR: sensor_msgs/PointCloud2 (Ouster, Velodyne, Hesai and Livox per-point time fields, as
//          fuse-import decodes them: fuse/rosbag/scan_conversion.hpp) or livox_ros_driver2/CustomMsg
// Best effort by default (it matches both best-effort and reliable writers), reliable on request
// (then it matches reliable writers only). Samples are decoded on the DDS threads, checked like
// every live input (SourceValidator), and handed over in arrival order; a sample that does not
// decode is counted by reason and named in the log, never silently dropped.
#pragma once

#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "fuse/io/sensor_source.hpp"
#include "fuse/io/source_validator.hpp"
#include "fuse/transport/transport.hpp"

namespace fuse::service {

struct Ros2InputConfig {
  std::string imu_topic = "/imu";
  std::string lidar_topic = "/points";
  std::string lidar_type = "pointcloud2";  ///< pointcloud2 | livox (livox_ros_driver2/CustomMsg)
  std::string time_field;                  ///< PointCloud2 per-point time field; "" finds it
  double accel_scale = 1.0;                ///< 9.80665 for drivers that write the acceleration in g
  bool reliable = false;
  std::function<bool()> should_stop;       ///< polled while waiting (SIGTERM)
  /// Throws std::invalid_argument naming the bad field.
  void validate() const;
};

/// "IMU_TOPIC,LIDAR_TOPIC" of --ros2 into the config; throws std::invalid_argument.
void parse_ros2_topics(const std::string& value, Ros2InputConfig& config);

class Ros2Source : public io::SensorSource {
 public:
  Ros2Source(transport::Participant& participant, const Ros2InputConfig& config, const TimeGateConfig& clock = {});
  ~Ros2Source() override;
  bool next(io::SensorEvent& out) override;
  std::optional<Eigen::Isometry3d> T_imu_lidar() const override { return std::nullopt; }
  const io::SourceStats& stats() const override { return stats_; }
  std::string describe() const override;

 private:
  void on_imu(const std::uint8_t* data, std::size_t size);
  void on_lidar(const std::uint8_t* data, std::size_t size);
  void push(io::SensorEvent&& event);  ///< mutex_ held

  Ros2InputConfig config_;
  std::mutex mutex_;
  std::condition_variable cv_;
  io::SourceValidator validator_;  ///< mutex_
  std::deque<io::SensorEvent> passed_;  ///< mutex_
  io::SourceStats stats_;  ///< next()'s thread: a copy of the validator's
  std::uint64_t scan_sequence_ = 0;  ///< mutex_
  std::unique_ptr<transport::RawReader> imu_reader_, lidar_reader_;
};

}  // namespace fuse::service

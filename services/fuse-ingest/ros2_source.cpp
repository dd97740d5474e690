// ROS 2 driver topics as a live sensor source (ros2_source.hpp).
#include "ros2_source.hpp"

#include <chrono>
#include <stdexcept>

#include "fuse/rosbag/scan_conversion.hpp"
#include "fuse/rosbag/sensor_msgs.hpp"
#include "fuse/transport/ros2.hpp"

namespace fuse::service {
namespace {

constexpr const char* kImuType = "sensor_msgs::msg::dds_::Imu_";
constexpr const char* kLivoxType = "livox_ros_driver2::msg::dds_::CustomMsg_";
constexpr std::size_t kMaxImuBytes = 4096;
constexpr std::size_t kMaxCloudBytes = std::size_t{64} << 20;
constexpr auto kStopPoll = std::chrono::milliseconds(100);

}  // namespace

void Ros2InputConfig::validate() const {
  transport::ros2::dds_topic(imu_topic);
  transport::ros2::dds_topic(lidar_topic);
  if (lidar_type != "pointcloud2" && lidar_type != "livox") {
    throw std::invalid_argument("--ros2-lidar-type '" + lidar_type + "': pointcloud2 or livox");
  }
  if (!time_field.empty() && !rosbag::known_time_field(time_field)) {
    throw std::invalid_argument("--time-field '" + time_field + "': one of t, time, timestamp, offset_time");
  }
}

void parse_ros2_topics(const std::string& value, Ros2InputConfig& config) {
  const auto comma = value.find(',');
  if (comma == std::string::npos || value.find(',', comma + 1) != std::string::npos) {
    throw std::invalid_argument("--ros2 takes IMU_TOPIC,LIDAR_TOPIC (e.g. /livox/imu,/livox/lidar), not '" + value + "'");
  }
  config.imu_topic = value.substr(0, comma);
  config.lidar_topic = value.substr(comma + 1);
}

Ros2Source::Ros2Source(transport::Participant& participant, const Ros2InputConfig& config, const TimeGateConfig& clock)
    : config_(config), validator_("ROS 2 topics " + config.imu_topic + ", " + config.lidar_topic, clock) {
  config_.validate();
  namespace ros2 = transport::ros2;
  transport::TopicQos qos = ros2::sensor_data_qos();
  if (config_.reliable) qos = ros2::default_qos();
  // Deep enough for a burst at IMU rate while the publishing thread is busy.
  qos.depth = 1000;
  imu_reader_ = participant.create_reader(ros2::dds_topic(config_.imu_topic), ros2::type_support(kImuType, kMaxImuBytes),
                                          qos, [this](const std::uint8_t* d, std::size_t n) { on_imu(d, n); });
  transport::TopicQos lidar_qos = qos;
  lidar_qos.depth = 10;
  const char* lidar_type = config_.lidar_type == "livox" ? kLivoxType : ros2::kPointCloud2Type;
  lidar_reader_ = participant.create_reader(ros2::dds_topic(config_.lidar_topic),
                                            ros2::type_support(lidar_type, kMaxCloudBytes), lidar_qos,
                                            [this](const std::uint8_t* d, std::size_t n) { on_lidar(d, n); });
}

Ros2Source::~Ros2Source() {
  imu_reader_.reset();  // no callback runs after this
  lidar_reader_.reset();
}

std::string Ros2Source::describe() const {
  return "ROS 2 topics " + config_.imu_topic + " (sensor_msgs/Imu) and " + config_.lidar_topic + " (" +
         (config_.lidar_type == "livox" ? "livox_ros_driver2/CustomMsg" : "sensor_msgs/PointCloud2") + ", " +
         (config_.reliable ? "reliable" : "best effort") + ")";
}

void Ros2Source::push(io::SensorEvent&& event) {
  validator_.check(std::move(event), passed_);
  cv_.notify_all();
}

void Ros2Source::on_imu(const std::uint8_t* data, std::size_t size) {
  try {
    const rosbag::ImuMsg msg = rosbag::decode_imu(data, size, rosbag::Serialization::kCdr, config_.imu_topic);
    io::SensorEvent ev;
    ev.kind = io::SensorEvent::Kind::kImu;
    ev.imu = rosbag::imu_to_sample(msg, config_.accel_scale);
    std::lock_guard<std::mutex> lock(mutex_);
    push(std::move(ev));
  } catch (const std::exception& e) {
    std::lock_guard<std::mutex> lock(mutex_);
    validator_.count("ros2_imu_undecodable", config_.imu_topic + ": " + e.what());
  }
}

void Ros2Source::on_lidar(const std::uint8_t* data, std::size_t size) {
  try {
    rosbag::PointCounts counts;
    LidarScan scan;
    if (config_.lidar_type == "livox") {
      scan = rosbag::livox_to_scan(rosbag::decode_livox_custom(data, size, rosbag::Serialization::kCdr, config_.lidar_topic),
                                   counts);
    } else {
      scan = rosbag::cloud_to_scan(
          rosbag::decode_point_cloud2(data, size, rosbag::Serialization::kCdr, config_.lidar_topic), config_.time_field,
          counts, config_.lidar_topic);
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (counts.nan_points > 0) validator_.count("nan_points", config_.lidar_topic + ": points with NaN dropped", counts.nan_points);
    if (counts.zero_points > 0) validator_.count("zero_points", config_.lidar_topic + ": points at the origin dropped", counts.zero_points);
    scan.sequence = ++scan_sequence_;
    io::SensorEvent ev;
    ev.kind = io::SensorEvent::Kind::kLidar;
    ev.scan = std::move(scan);
    push(std::move(ev));
  } catch (const std::exception& e) {
    std::lock_guard<std::mutex> lock(mutex_);
    validator_.count("ros2_scan_undecodable", config_.lidar_topic + ": " + e.what());
  }
}

bool Ros2Source::next(io::SensorEvent& out) {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    stats_ = validator_.stats();  // the consumer's copy: stats() is read on its thread
    if (!passed_.empty()) {
      out = std::move(passed_.front());
      passed_.pop_front();
      return true;
    }
    if (config_.should_stop && config_.should_stop()) {
      validator_.finish();
      stats_ = validator_.stats();
      return false;
    }
    cv_.wait_for(lock, kStopPoll);
  }
}

}  // namespace fuse::service

// fuse-import's conversion: picks the IMU and LiDAR topics of a bag (by type when not named),
// decodes every message of them and writes ImuSample / LidarScan into the project's recording
// (common/io recording.hpp). Messages that cannot be used are skipped and counted by reason.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>

#include "fuse/io/recording.hpp"
#include "fuse/rosbag/bag_reader.hpp"
#include "fuse/rosbag/scan_conversion.hpp"

namespace fuse::import {

/// The topics cannot be chosen (none, several, or a named one of the wrong type): exit code 2.
class TopicError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ImportConfig {
  std::string imu_topic;    ///< "" = the only sensor_msgs/Imu topic
  std::string lidar_topic;  ///< "" = the only PointCloud2 / Livox CustomMsg topic
  std::string time_field;   ///< "" = first present of t, time, timestamp, offset_time
  double accel_scale = 1.0; ///< 9.80665 for --imu-accel-unit g
};

enum class LidarKind { kPointCloud2, kLivoxCustom };

struct TopicChoice {
  std::size_t imu = 0, lidar = 0;  ///< indexes into BagReader::topics()
  LidarKind lidar_kind = LidarKind::kPointCloud2;
};

/// Skip reasons (keys of ImportSummary::skipped).
namespace skip {
inline constexpr const char* kMalformedImu = "malformed_imu_message";
inline constexpr const char* kMalformedCloud = "malformed_lidar_message";
inline constexpr const char* kUnusableCloud = "unusable_cloud";  ///< no time field, inconsistent layout
inline constexpr const char* kEmptyScan = "empty_scan";
inline constexpr const char* kImuTimeNotIncreasing = "imu_time_not_increasing";
inline constexpr const char* kScanTimeNotIncreasing = "scan_end_not_increasing";
}  // namespace skip

struct ImportSummary {
  std::uint64_t imu_messages = 0, lidar_messages = 0;  ///< read from the bag
  std::uint64_t imu_written = 0, scans_written = 0;
  rosbag::PointCounts points;
  std::map<std::string, std::uint64_t> skipped;  ///< reason -> messages
  std::uint64_t other_topic_messages = 0;        ///< messages of topics not imported
  double imu_mean_accel_norm = 0.0;              ///< after scaling, over the written samples
  std::string error;                             ///< the bag stopped being readable (InputError)
};

/// True for "sensor_msgs/Imu" (ROS 1 or ROS 2 spelling).
bool is_imu_type(const std::string& type);
/// PointCloud2 or Livox CustomMsg (livox_ros_driver, livox_ros_driver2).
bool is_lidar_type(const std::string& type, LidarKind* kind = nullptr);

/// Chooses the topics; throws TopicError listing the candidates when it cannot.
TopicChoice choose_topics(const rosbag::BagReader& bag, const ImportConfig& config);

/// The number of messages of the chosen topics, when the bag declares both (index, metadata or
/// statistics); unset when it does not (an unindexed ROS 1 bag, an MCAP file without statistics).
std::optional<std::uint64_t> expected_messages(const rosbag::BagReader& bag, const TopicChoice& topics);

/// Reads the chosen topics and writes the recording, logging a progress line every 5 s (share done
/// and time left when expected_messages() is known, speed against the bag's receive time). An
/// InputError of the bag mid-way ends the import (what was converted is kept) and is reported in
/// ImportSummary::error.
ImportSummary import_bag(rosbag::BagReader& bag, const TopicChoice& topics, const ImportConfig& config,
                         io::RecordingWriter& writer);

}  // namespace fuse::import

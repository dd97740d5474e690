// Ouster packets recorded by the ouster_ros driver in a bag (ROS 1 or rosbag2, read through
// fuse_rosbag): ouster_ros/PacketMsg messages (one field, uint8[] buf: one UDP payload) on a
// lidar-packets and an IMU-packets topic, and the sensor metadata JSON as a std_msgs/String on
// a metadata topic (or given as a file instead). The payloads go through the same
// ouster::Stream as UDP datagrams (ouster_stream.hpp), so scans and IMU samples are exactly
// what the pcap and live sources make of the same packets.
//
// Topics are chosen by type and name: the PacketMsg topics whose names end in "lidar_packets"
// and "imu_packets", the String topic ending in "metadata"; none or several is an InputError
// listing the candidates. Some ouster_ros versions store a buffer one byte longer than the
// packet; that trailing byte is dropped when the length is exactly one more than the profile's.
#pragma once

#include <deque>
#include <memory>
#include <optional>
#include <string>

#include "fuse/io/ouster_stream.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/io/source_validator.hpp"
#include "fuse/rosbag/bag_reader.hpp"

namespace fuse::service {

class OusterBagSource : public io::SensorSource {
 public:
  /// `metadata_file` empty: the metadata comes from the bag. Throws io::InputError.
  OusterBagSource(const std::string& bag, const std::string& metadata_file);

  bool next(io::SensorEvent& out) override;
  std::optional<Eigen::Isometry3d> T_imu_lidar() const override { return meta_.T_imu_sensor(); }
  const io::SourceStats& stats() const override { return validator_.stats(); }
  std::string describe() const override;

  const io::ouster::Metadata& metadata() const { return meta_; }
  const io::ouster::Stream& stream() const { return *stream_; }

  /// True when the bag holds ouster_ros/PacketMsg topics (what this source reads).
  static bool holds_ouster_packets(const std::string& bag);

 private:
  std::string bag_path_, metadata_source_;
  std::unique_ptr<rosbag::BagReader> bag_;
  std::size_t lidar_topic_ = 0, imu_topic_ = 0;
  bool have_imu_topic_ = false;
  io::ouster::Metadata meta_;
  io::SourceValidator validator_;
  std::unique_ptr<io::ouster::Stream> stream_;
  std::deque<io::SensorEvent> ready_;   ///< assembled, not yet checked
  std::deque<io::SensorEvent> passed_;  ///< checked (SourceValidator)
  bool finished_ = false;
  std::string error_;
};

}  // namespace fuse::service

// One interface over the bag formats fuse-import reads: ROS 1 bags (v2.0) and rosbag2 bags
// (a directory with metadata.yaml, or a single .db3 / .mcap storage file). Messages come in
// receive-time order with their topic's type and serialisation (ROS 1 or CDR).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace fuse::rosbag {

enum class Serialization { kRos1, kCdr };

struct BagTopic {
  std::string name;
  std::string type;  ///< as stored: "sensor_msgs/Imu" (ROS 1) or "sensor_msgs/msg/Imu" (ROS 2)
  Serialization serialization = Serialization::kCdr;
  std::uint64_t message_count = 0;  ///< as the bag's index / metadata declares it
};

struct BagMessage {
  std::size_t topic = 0;      ///< index into topics()
  std::uint64_t time_ns = 0;  ///< receive (log) time
  std::vector<std::uint8_t> data;
};

class BagReader {
 public:
  virtual ~BagReader() = default;
  virtual const std::vector<BagTopic>& topics() const = 0;
  virtual std::uint64_t start_time_ns() const = 0;
  virtual std::uint64_t end_time_ns() const = 0;
  /// Starts (or restarts) iteration over `topics` (names; empty: all).
  virtual void start(const std::vector<std::string>& topics = {}) = 0;
  /// Next message in time order; false at the end. Throws fuse::io::InputError on bad input.
  virtual bool next(BagMessage& out) = 0;
  virtual std::string describe() const = 0;
};

/// "sensor_msgs/msg/Imu" -> "sensor_msgs/Imu"; ROS 1 names are returned unchanged.
std::string ros1_type_name(const std::string& type);

/// Opens a ROS 1 bag (.bag), a rosbag2 directory (metadata.yaml), or a rosbag2 storage file
/// (.db3, .mcap). Throws fuse::io::InputError naming what is wrong.
std::unique_ptr<BagReader> open_bag(const std::string& path);

}  // namespace fuse::rosbag

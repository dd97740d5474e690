// The FUSE topics fuse-record knows (the transport QoS table, common/transport qos.cpp, with the
// wire types of idl/fuse_msgs.idl): for each its IDL type, what the transport needs to subscribe
// to it, and a check of one received sample.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "fuse/transport/transport.hpp"

namespace fuse::record {

/// Result of checking one sample: ok, or why not; for imu and lidar/scan also the sample's own
/// time (IMU t, scan end time: the log time fuse-sim writes, which fuse-ingest replays by).
struct SampleCheck {
  bool ok = false;
  std::string error;
  std::optional<double> sensor_time;
};

struct TopicType {
  std::string topic;
  std::string type_name;  ///< IDL name, also the MCAP schema name (e.g. "fuse_msgs::ImuSample")
  transport::TypeSupport support;
  transport::TopicQos qos;
  std::function<SampleCheck(const std::uint8_t* data, std::size_t size)> check;
};

/// Every topic of the QoS table, imu and lidar/scan first.
const std::vector<TopicType>& fuse_topics();

}  // namespace fuse::record

// Every topic's QoS, in one place (DESIGN §3). Services and tests name topics only through
// these constants; topic_qos() refuses a topic it does not know.
#pragma once

#include <string>

#include "fuse/transport/transport.hpp"

namespace fuse::transport {

namespace topics {
inline constexpr const char* kImu = "imu";
inline constexpr const char* kLidarScan = "lidar/scan";
inline constexpr const char* kOdometry = "state/odometry";
inline constexpr const char* kCorrected = "state/corrected";
inline constexpr const char* kCorrection = "update/correction";
inline constexpr const char* kObservation = "map/observation";
/// Every processed scan's deskewed points in the world frame (fuse-update), for viewers.
inline constexpr const char* kWorldScan = "update/world_scan";
inline constexpr const char* kMapChunk = "map/chunk";
inline constexpr const char* kMapStatus = "map/status";
inline constexpr const char* kHealth = "health";
}  // namespace topics

namespace services {
inline constexpr const char* kQuery = "query";
inline constexpr const char* kHistory = "history";
inline constexpr const char* kMapControl = "map/control";
/// An initial pose in the saved map (served by fuse-update, which holds the map and the search).
inline constexpr const char* kSetPose = "update/set_pose";
}  // namespace services

/// QoS of a topic (or of an RPC's "rpc/<service>/request" and "rpc/<service>/reply" topics).
/// Throws std::invalid_argument for a topic not in the table.
const TopicQos& topic_qos(const std::string& topic);

/// `qos` with another KEEP_LAST depth (std::invalid_argument unless 1 <= depth <= 1000000).
TopicQos with_depth(TopicQos qos, int depth);

}  // namespace fuse::transport

// Foxglove's message schemas that its 3D panel draws (foxglove.PoseInFrame, PosesInFrame,
// FrameTransforms, PointCloud), JSON-encoded with their JSON Schemas, plus fuse.Health. Times are
// sensor times in seconds; frames are named by the caller ("world", "imu", "lidar").
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace fuse::foxglove {

/// The Foxglove channel names FUSE writes: fuse-viz (live), fuse-record and fuse-sim (files).
namespace topics {
inline constexpr const char* kPose = "/fuse/pose";              ///< PoseInFrame, IMU rate
inline constexpr const char* kPoseScan = "/fuse/pose_scan";     ///< PoseInFrame, scan rate
inline constexpr const char* kTf = "/tf";                       ///< FrameTransforms world -> imu
inline constexpr const char* kTfStatic = "/tf_static";          ///< FrameTransforms imu -> lidar
inline constexpr const char* kScan = "/fuse/scan";              ///< PointCloud
inline constexpr const char* kMap = "/fuse/map";                ///< PointCloud, whole
inline constexpr const char* kTrajectory = "/fuse/trajectory";  ///< PosesInFrame
inline constexpr const char* kHealth = "/fuse/health";          ///< fuse.Health
}  // namespace topics

/// The schema name and its JSON Schema text, as a channel advertises them.
struct JsonSchema {
  std::string name;
  std::string text;
};
const JsonSchema& pose_in_frame_schema();     ///< foxglove.PoseInFrame
const JsonSchema& poses_in_frame_schema();    ///< foxglove.PosesInFrame
const JsonSchema& frame_transforms_schema();  ///< foxglove.FrameTransforms
const JsonSchema& point_cloud_schema();       ///< foxglove.PointCloud
const JsonSchema& health_schema();            ///< fuse.Health

/// Seconds to {sec, nsec}, and to nanoseconds for a log time (negative times clamp to 0).
std::uint64_t to_nanoseconds(double t);

struct StampedTransform {
  double t = 0.0;
  std::string parent;
  std::string child;
  Eigen::Isometry3d T_parent_child = Eigen::Isometry3d::Identity();
};

std::string pose_in_frame_json(double t, const std::string& frame, const Eigen::Isometry3d& T_frame_body);
std::string poses_in_frame_json(double t, const std::string& frame, const std::vector<Eigen::Isometry3d>& poses);
std::string frame_transforms_json(const std::vector<StampedTransform>& transforms);
/// A cloud of x, y, z float32 points (stride 12, little-endian, base64 in `data`) in `frame`
/// with the identity as its pose. `xyz` holds 3 n floats.
std::string point_cloud_json(double t, const std::string& frame, const std::vector<float>& xyz);

/// One service's heartbeat, as fuse.Health.
struct HealthView {
  double t = 0.0;
  std::string service;
  std::uint64_t instance = 0;
  std::string state;
  double uptime_s = 0.0;
  std::string last_error;
  std::map<std::string, std::uint64_t> counters;
};
std::string health_json(const HealthView& health);

/// RFC 4648 base64 of `size` bytes.
std::string base64(const std::uint8_t* data, std::size_t size);

}  // namespace fuse::foxglove

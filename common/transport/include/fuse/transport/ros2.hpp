// ROS 2 on the wire, without ROS 2: the DDS names and CDR encodings of the few ROS 2 messages
// FUSE publishes (docs/architecture.md, "ROS 2"), so that ROS 2 nodes of the same DDS domain see
// FUSE's odometry, transforms, clouds and diagnostics with no bridge.
//   - topic: "rt" + the ROS topic name ("/fuse/odometry" -> "rt/fuse/odometry");
//   - type: "<package>::msg::dds_::<Type>_" (the rosidl DDS naming of Humble and Jazzy);
//   - samples: XCDR1 plain CDR, little-endian, with the 4-byte encapsulation header, the fields in
//     the order of the .msg definitions (nested messages inline, sequences as uint32 length + items).
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "fuse/transport/transport.hpp"

namespace fuse::transport::ros2 {

inline constexpr const char* kOdometryType = "nav_msgs::msg::dds_::Odometry_";
inline constexpr const char* kTfMessageType = "tf2_msgs::msg::dds_::TFMessage_";
inline constexpr const char* kPointCloud2Type = "sensor_msgs::msg::dds_::PointCloud2_";
inline constexpr const char* kDiagnosticArrayType = "diagnostic_msgs::msg::dds_::DiagnosticArray_";

/// The DDS topic of a ROS 2 topic name: "rt" + name. Throws std::invalid_argument unless the
/// name is absolute ("/a/b"), of letters, digits, '_' and '/', with no empty or numeric-first token.
std::string dds_topic(const std::string& ros_topic);

/// ROS 2's QoS profiles as FUSE's transport expresses them (rmw_qos_profile_*): sensor data
/// (best effort, volatile, 5), default (reliable, volatile, 10), and /tf_static's (reliable,
/// transient local, 1: a late subscriber gets the static transforms).
TopicQos sensor_data_qos();
TopicQos default_qos();
TopicQos transient_local_qos();

/// builtin_interfaces/Time from seconds (negative times clamp to 0).
struct Stamp {
  std::int32_t sec = 0;
  std::uint32_t nanosec = 0;
};
Stamp stamp_of(double t);

/// nav_msgs/Odometry: the pose of child_frame in frame, its covariance (6x6 row-major,
/// x y z rot_x rot_y rot_z), the twist in child_frame and its covariance.
struct Odometry {
  double t = 0.0;
  std::string frame;
  std::string child_frame;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  std::array<double, 36> pose_covariance{};
  Eigen::Vector3d linear_velocity = Eigen::Vector3d::Zero();   ///< in child_frame
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();  ///< in child_frame
  std::array<double, 36> twist_covariance{};
};
Bytes encode(const Odometry& m);

/// One geometry_msgs/TransformStamped of a tf2_msgs/TFMessage.
struct Transform {
  double t = 0.0;
  std::string parent;
  std::string child;
  Eigen::Isometry3d T_parent_child = Eigen::Isometry3d::Identity();
};
Bytes encode_tf(const std::vector<Transform>& transforms);

/// sensor_msgs/PointCloud2 of x, y, z float32 points (an unordered cloud: height 1), `xyz` 3 n floats.
Bytes encode_cloud(double t, const std::string& frame, const std::vector<float>& xyz);

/// One diagnostic_msgs/DiagnosticStatus of a DiagnosticArray.
struct DiagnosticStatus {
  std::uint8_t level = 0;  ///< 0 OK, 1 WARN, 2 ERROR, 3 STALE
  std::string name;
  std::string message;
  std::string hardware_id;
  std::vector<std::pair<std::string, std::string>> values;
};
Bytes encode_diagnostics(double t, const std::vector<DiagnosticStatus>& status);

/// The type support a writer of one of these types registers: keyless, `max_bytes` at most.
TypeSupport type_support(const char* type_name, std::size_t max_bytes);

}  // namespace fuse::transport::ros2

// ROS 2 messages in CDR (fuse/transport/ros2.hpp). Field order and types follow the .msg
// definitions of std_msgs, geometry_msgs, nav_msgs, tf2_msgs, sensor_msgs and diagnostic_msgs.
#include "fuse/transport/ros2.hpp"

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>

#include <cctype>
#include <cmath>
#include <cstring>
#include <functional>
#include <stdexcept>

namespace fuse::transport::ros2 {
namespace {

using eprosima::fastcdr::Cdr;
using eprosima::fastcdr::FastBuffer;

constexpr std::uint8_t kFloat32 = 7;  // sensor_msgs/PointField FLOAT32
constexpr std::uint32_t kXyzStep = 12;
constexpr double kNanosecondsPerSecond = 1e9;

/// Serialises with `body` into a buffer that grows until it fits.
Bytes serialised(std::size_t guess, const std::function<void(Cdr&)>& body) {
  for (std::size_t size = std::max<std::size_t>(guess, 256);; size *= 2) {
    Bytes out(size);
    FastBuffer buffer(reinterpret_cast<char*>(out.data()), out.size());
    Cdr cdr(buffer, Cdr::LITTLE_ENDIANNESS, Cdr::DDS_CDR);
    try {
      cdr.serialize_encapsulation();
      body(cdr);
    } catch (const eprosima::fastcdr::exception::NotEnoughMemoryException&) {
      continue;
    }
    out.resize(cdr.getSerializedDataLength());
    return out;
  }
}

void header(Cdr& cdr, double t, const std::string& frame) {
  const Stamp s = stamp_of(t);
  cdr << s.sec << s.nanosec << frame;
}
void vector3(Cdr& cdr, const Eigen::Vector3d& v) { cdr << v.x() << v.y() << v.z(); }
void quaternion(Cdr& cdr, const Eigen::Quaterniond& q) { cdr << q.x() << q.y() << q.z() << q.w(); }
void pose(Cdr& cdr, const Eigen::Isometry3d& T) {
  vector3(cdr, T.translation());  // geometry_msgs/Point: the same three float64
  quaternion(cdr, Eigen::Quaterniond(T.linear()).normalized());
}
void covariance(Cdr& cdr, const std::array<double, 36>& c) {
  for (const double v : c) cdr << v;  // float64[36]: a fixed array, no length
}

bool valid_token_start(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_'; }

}  // namespace

std::string dds_topic(const std::string& ros_topic) {
  const auto bad = [&](const std::string& why) {
    return std::invalid_argument("ROS 2 topic '" + ros_topic + "': " + why);
  };
  if (ros_topic.size() < 2 || ros_topic.front() != '/') throw bad("must be absolute, e.g. /fuse/odometry");
  if (ros_topic.back() == '/') throw bad("must not end with '/'");
  bool token_start = true;
  for (std::size_t i = 1; i < ros_topic.size(); ++i) {
    const char c = ros_topic[i];
    if (c == '/') {
      if (token_start) throw bad("has an empty token");
      token_start = true;
      continue;
    }
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') throw bad("may hold only letters, digits, '_' and '/'");
    if (token_start && !valid_token_start(c)) throw bad("a token must not start with a digit");
    token_start = false;
  }
  return "rt" + ros_topic;
}

TopicQos sensor_data_qos() { return TopicQos{Reliability::kBestEffort, Durability::kVolatile, 5}; }
TopicQos default_qos() { return TopicQos{Reliability::kReliable, Durability::kVolatile, 10}; }
TopicQos transient_local_qos() { return TopicQos{Reliability::kReliable, Durability::kTransientLocal, 1}; }

Stamp stamp_of(double t) {
  if (!(t > 0.0) || !std::isfinite(t)) return {};
  const auto ns = static_cast<std::int64_t>(std::llround(t * kNanosecondsPerSecond));
  return Stamp{static_cast<std::int32_t>(ns / 1000000000), static_cast<std::uint32_t>(ns % 1000000000)};
}

Bytes encode(const Odometry& m) {
  return serialised(512 + m.frame.size() + m.child_frame.size(), [&](Cdr& cdr) {
    header(cdr, m.t, m.frame);
    cdr << m.child_frame;
    pose(cdr, m.pose);
    covariance(cdr, m.pose_covariance);
    vector3(cdr, m.linear_velocity);
    vector3(cdr, m.angular_velocity);
    covariance(cdr, m.twist_covariance);
  });
}

Bytes encode_tf(const std::vector<Transform>& transforms) {
  return serialised(128 * (transforms.size() + 1), [&](Cdr& cdr) {
    cdr << static_cast<std::uint32_t>(transforms.size());
    for (const Transform& tf : transforms) {
      header(cdr, tf.t, tf.parent);
      cdr << tf.child;
      vector3(cdr, tf.T_parent_child.translation());
      quaternion(cdr, Eigen::Quaterniond(tf.T_parent_child.linear()).normalized());
    }
  });
}

Bytes encode_cloud(double t, const std::string& frame, const std::vector<float>& xyz) {
  const std::uint32_t n = static_cast<std::uint32_t>(xyz.size() / 3);
  return serialised(256 + xyz.size() * sizeof(float), [&](Cdr& cdr) {
    header(cdr, t, frame);
    cdr << std::uint32_t{1} << n;  // height, width
    cdr << std::uint32_t{3};       // fields
    for (std::uint32_t i = 0; i < 3; ++i) {
      cdr << std::string(1, static_cast<char>('x' + i)) << std::uint32_t{4 * i} << kFloat32 << std::uint32_t{1};
    }
    cdr << false << kXyzStep << kXyzStep * n;  // is_bigendian, point_step, row_step
    cdr << n * kXyzStep;                        // data: uint8[] length, then the bytes
    if (n > 0) cdr.serializeArray(reinterpret_cast<const std::uint8_t*>(xyz.data()), n * kXyzStep);
    cdr << true;  // is_dense: every point is finite
  });
}

Bytes encode_diagnostics(double t, const std::vector<DiagnosticStatus>& status) {
  return serialised(1024, [&](Cdr& cdr) {
    header(cdr, t, "");
    cdr << static_cast<std::uint32_t>(status.size());
    for (const DiagnosticStatus& s : status) {
      cdr << s.level << s.name << s.message << s.hardware_id;
      cdr << static_cast<std::uint32_t>(s.values.size());
      for (const auto& [key, value] : s.values) cdr << key << value;
    }
  });
}

TypeSupport type_support(const char* type_name, std::size_t max_bytes) { return TypeSupport{type_name, false, max_bytes}; }

}  // namespace fuse::transport::ros2

#include "fuse/rosbag/sensor_msgs.hpp"

#include "fuse/rosbag/message_reader.hpp"

namespace fuse::rosbag {

namespace {

Eigen::Vector3d vector3(MessageReader& r) {
  const double x = r.f64(), y = r.f64(), z = r.f64();
  return {x, y, z};
}

void skip_covariance(MessageReader& r) {
  for (int i = 0; i < 9; ++i) r.f64();  // float64[9]: a fixed array, no length
}

/// Trailing bytes: a ROS 1 message ends exactly; CDR buffers may carry up to 7 bytes of padding.
void expect_end(const MessageReader& r) {
  if (r.remaining() > (r.cdr() ? 7u : 0u)) r.fail(std::to_string(r.remaining()) + " bytes left over after the message");
}

}  // namespace

std::size_t point_field_size(std::uint8_t datatype) {
  switch (static_cast<PointFieldType>(datatype)) {
    case PointFieldType::kInt8:
    case PointFieldType::kUint8: return 1;
    case PointFieldType::kInt16:
    case PointFieldType::kUint16: return 2;
    case PointFieldType::kInt32:
    case PointFieldType::kUint32:
    case PointFieldType::kFloat32: return 4;
    case PointFieldType::kFloat64: return 8;
  }
  return 0;
}

ImuMsg decode_imu(const std::uint8_t* data, std::size_t size, Serialization s, const std::string& context) {
  MessageReader r(data, size, s, context + " (sensor_msgs/Imu)");
  ImuMsg m;
  m.stamp_ns = r.header(&m.frame_id);
  const double qx = r.f64(), qy = r.f64(), qz = r.f64(), qw = r.f64();
  m.orientation = Eigen::Quaterniond(qw, qx, qy, qz);
  skip_covariance(r);
  m.angular_velocity = vector3(r);
  skip_covariance(r);
  m.linear_acceleration = vector3(r);
  skip_covariance(r);
  expect_end(r);
  return m;
}

PointCloud2Msg decode_point_cloud2(const std::uint8_t* data, std::size_t size, Serialization s,
                                   const std::string& context) {
  MessageReader r(data, size, s, context + " (sensor_msgs/PointCloud2)");
  PointCloud2Msg m;
  m.stamp_ns = r.header(&m.frame_id);
  m.height = r.u32();
  m.width = r.u32();
  const std::uint32_t n_fields = r.sequence_length(4 + 1 + 4 + 1 + 4);  // smallest PointField
  m.fields.resize(n_fields);
  for (auto& f : m.fields) {
    f.name = r.string();
    f.offset = r.u32();
    f.datatype = r.u8();
    f.count = r.u32();
  }
  m.is_bigendian = r.boolean();
  m.point_step = r.u32();
  m.row_step = r.u32();
  const std::uint32_t n = r.sequence_length(1);
  const std::uint8_t* p = r.bytes(n);
  m.data.assign(p, p + n);
  m.is_dense = r.boolean();
  expect_end(r);
  return m;
}

LivoxCustomMsg decode_livox_custom(const std::uint8_t* data, std::size_t size, Serialization s,
                                   const std::string& context) {
  MessageReader r(data, size, s, context + " (livox CustomMsg)");
  LivoxCustomMsg m;
  m.stamp_ns = r.header(&m.frame_id);
  m.timebase = r.u64();
  m.point_num = r.u32();
  m.lidar_id = r.u8();
  r.bytes(3);  // uint8[3] rsvd
  const std::uint32_t n = r.sequence_length(4 * 4 + 3);
  m.points.resize(n);
  for (auto& pt : m.points) {
    pt.offset_time = r.u32();
    pt.x = r.f32();
    pt.y = r.f32();
    pt.z = r.f32();
    pt.reflectivity = r.u8();
    pt.tag = r.u8();
    pt.line = r.u8();
  }
  expect_end(r);
  if (m.point_num != n) {
    r.fail("point_num " + std::to_string(m.point_num) + " differs from the " + std::to_string(n) + " points present");
  }
  return m;
}

}  // namespace fuse::rosbag

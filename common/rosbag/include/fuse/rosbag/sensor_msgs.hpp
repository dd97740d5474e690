// Decoders of the sensor messages fuse-import converts, in ROS 1 serialisation or CDR (see
// message_reader.hpp), following the message definitions:
//  - sensor_msgs/Imu: Header, geometry_msgs/Quaternion orientation, float64[9] covariance,
//    geometry_msgs/Vector3 angular_velocity, float64[9], Vector3 linear_acceleration, float64[9].
//  - sensor_msgs/PointCloud2: Header, uint32 height, uint32 width, PointField[] fields
//    (string name, uint32 offset, uint8 datatype, uint32 count), bool is_bigendian,
//    uint32 point_step, uint32 row_step, uint8[] data, bool is_dense.
//  - livox_ros_driver/CustomMsg and livox_ros_driver2/CustomMsg (same layout): Header,
//    uint64 timebase, uint32 point_num, uint8 lidar_id, uint8[3] rsvd, CustomPoint[] points
//    (uint32 offset_time, float32 x, y, z, uint8 reflectivity, tag, line).
// A message that does not parse, or that has bytes left over, throws fuse::io::InputError.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "fuse/rosbag/bag_reader.hpp"

namespace fuse::rosbag {

struct ImuMsg {
  std::uint64_t stamp_ns = 0;
  std::string frame_id;
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d linear_acceleration = Eigen::Vector3d::Zero();
};

/// sensor_msgs/PointField datatype constants.
enum class PointFieldType : std::uint8_t {
  kInt8 = 1, kUint8 = 2, kInt16 = 3, kUint16 = 4, kInt32 = 5, kUint32 = 6, kFloat32 = 7, kFloat64 = 8,
};
/// Size in bytes of a PointField datatype; 0 for an unknown one.
std::size_t point_field_size(std::uint8_t datatype);

struct PointField {
  std::string name;
  std::uint32_t offset = 0;
  std::uint8_t datatype = 0;
  std::uint32_t count = 1;
};

struct PointCloud2Msg {
  std::uint64_t stamp_ns = 0;
  std::string frame_id;
  std::uint32_t height = 0, width = 0;
  std::vector<PointField> fields;
  bool is_bigendian = false;
  std::uint32_t point_step = 0, row_step = 0;
  std::vector<std::uint8_t> data;
  bool is_dense = false;
};

struct LivoxPoint {
  std::uint32_t offset_time = 0;  ///< ns after timebase
  float x = 0, y = 0, z = 0;
  std::uint8_t reflectivity = 0, tag = 0, line = 0;
};

struct LivoxCustomMsg {
  std::uint64_t stamp_ns = 0;
  std::string frame_id;
  std::uint64_t timebase = 0;  ///< ns
  std::uint32_t point_num = 0;
  std::uint8_t lidar_id = 0;
  std::vector<LivoxPoint> points;
};

ImuMsg decode_imu(const std::uint8_t* data, std::size_t size, Serialization s, const std::string& context);
PointCloud2Msg decode_point_cloud2(const std::uint8_t* data, std::size_t size, Serialization s,
                                   const std::string& context);
LivoxCustomMsg decode_livox_custom(const std::uint8_t* data, std::size_t size, Serialization s,
                                   const std::string& context);

}  // namespace fuse::rosbag

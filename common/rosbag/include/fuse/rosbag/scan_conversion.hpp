// Conversion of decoded ROS sensor messages into the project's sensor types.
//
// PointCloud2 per-point time fields, by the conventions of the drivers that write them:
//   "t"           uint32 ns after the header stamp          (ouster_ros)
//   "time"        float32 s relative to the header stamp     (velodyne_pointcloud; may be < 0)
//   "timestamp"   float64 absolute s                         (Hesai drivers)
//   "offset_time" uint32 ns after the header stamp           (livox_ros_driver2 PointCloud2)
// The scan starts at its earliest point and ends at its latest; t_rel is measured from the start.
// x, y, z are required; intensity comes from "intensity" (else "reflectivity"), the ring from
// "ring" (else "line"). point_step, row_step, height/width, is_bigendian and every field's
// datatype and extent are checked against the data; a cloud that cannot be read throws
// fuse::io::InputError, as does a cloud whose point times span more than 10 s or lie more than
// an hour from the header stamp (a wrong time field or unit). Points with a NaN/inf coordinate,
// intensity or time and points at the origin (drivers' "no return") are dropped and counted.
#pragma once

#include <cstdint>
#include <string>

#include "fuse/core/types.hpp"
#include "fuse/rosbag/sensor_msgs.hpp"

namespace fuse::rosbag {

/// Per-point time field conventions fuse-import knows (the names above).
bool known_time_field(const std::string& name);

struct PointCounts {
  std::uint64_t kept = 0;
  std::uint64_t nan_points = 0;   ///< NaN/inf coordinate or time
  std::uint64_t zero_points = 0;  ///< exactly at the origin (no return)
};

/// `time_field`: one of the names above, or "" to take the first present in the order above.
/// Throws InputError when no (or an unknown) time field is present or the cloud is inconsistent.
LidarScan cloud_to_scan(const PointCloud2Msg& cloud, const std::string& time_field, PointCounts& counts,
                        const std::string& context);

/// Livox CustomMsg: point time = timebase + offset_time; intensity = reflectivity, ring = line.
LidarScan livox_to_scan(const LivoxCustomMsg& msg, PointCounts& counts);

/// `accel_scale`: 1 for m/s^2, 9.80665 when the driver writes the acceleration in g.
ImuSample imu_to_sample(const ImuMsg& msg, double accel_scale);

}  // namespace fuse::rosbag

// Sensor and pose types shared by every FUSE library. Plain C++/Eigen: no DDS or protobuf type
// ever reaches the estimator (the io and transport layers convert at the boundary).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace fuse {

/// One IMU sample in the IMU frame. gyro in rad/s, accel (specific force) in m/s^2.
struct ImuSample {
  double t = 0.0;  ///< seconds, sensor clock
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();
  std::uint64_t sequence = 0;
};

/// One LiDAR return in the LiDAR frame, as measured (not deskewed).
struct LidarPoint {
  float x = 0.f, y = 0.f, z = 0.f;
  float intensity = 0.f;
  float t_rel = 0.f;       ///< seconds from the scan's start time
  std::uint16_t ring = 0;  ///< line / ring index
};

/// One LiDAR scan (frame). Points carry their own time offset from t_start.
struct LidarScan {
  double t_start = 0.0;  ///< seconds
  double t_end = 0.0;    ///< seconds; the scan "arrives" at t_end
  std::uint64_t sequence = 0;
  std::vector<LidarPoint> points;
};

/// A timestamped rigid pose, T_world_body: p_world = q * p_body + p.
struct StampedPose {
  double t = 0.0;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
};

}  // namespace fuse

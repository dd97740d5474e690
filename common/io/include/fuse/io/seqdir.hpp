// Plain sequence directory, the exchange format with other LiDAR-inertial tools:
//   raw/%06d.bin  per point float32 x, y, z, intensity, t_rel, ring (LiDAR frame, not deskewed)
//   scans.csv     idx,t_start,t_end (absolute seconds)
//   imu.csv       timestamp,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z
//                 (timestamp in ns when above 1e10, else seconds; rad/s, m/s^2, IMU frame;
//                 SeqdirWriter writes integer ns, or seconds for times below 10 s)
//   calib.yaml    T_imu_lidar: {translation: [x,y,z], rotation_xyzw: [qx,qy,qz,qw]}
//   gt_tum.txt    true IMU pose at each scan end (TUM), when known
#pragma once

#include <Eigen/Geometry>
#include <fstream>
#include <string>
#include <vector>

#include "fuse/core/types.hpp"

namespace fuse::io {

/// Writes a sequence directory incrementally (scans and IMU samples in any interleaving).
class SeqdirWriter {
 public:
  SeqdirWriter(const std::string& dir, const Eigen::Isometry3d& T_imu_lidar);
  void write(const ImuSample& imu);
  void write(const LidarScan& scan);  ///< scan index = number of scans written before
  void write_groundtruth(const std::vector<StampedPose>& poses_at_scan_end);
  void close();

 private:
  std::string dir_;
  std::ofstream scans_csv_, imu_csv_;
  std::size_t scan_index_ = 0;
};

}  // namespace fuse::io

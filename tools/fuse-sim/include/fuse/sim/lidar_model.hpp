// LiDAR measurement model: every shot is ray-cast at its own firing time from the TRUE LiDAR pose
// at that instant, T_WL(t) = T_WI(t) T_IL, and reported in the LiDAR frame of that instant (not
// deskewed). A return needs blind <= range <= max range; the measured range carries Gaussian
// noise; the beam direction jitters by a small angular noise (the point is reported along the
// nominal direction). Intensity = 255 * reflectivity * (a + (1 - a) |cos incidence|).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "fuse/core/types.hpp"
#include "fuse/sim/lidar_pattern.hpp"
#include "fuse/sim/random.hpp"
#include "fuse/sim/trajectory.hpp"
#include "fuse/sim/world.hpp"

namespace fuse::sim {

class LidarSimulator {
 public:
  /// world and trajectory must outlive the simulator.
  LidarSimulator(const LidarConfig& config, const World& world, const Trajectory& trajectory,
                 const Eigen::Isometry3d& T_imu_lidar, std::uint64_t seed);

  /// Frame k spans [t0 + k T, t0 + (k + 1) T] (T: frame period); points in firing order.
  fuse::LidarScan scan(std::uint64_t frame_index, double t0);

 private:
  LidarConfig config_;
  const World& world_;
  const Trajectory& trajectory_;
  Eigen::Isometry3d T_imu_lidar_;
  Rng rng_;
  std::vector<Shot> shots_;
};

}  // namespace fuse::sim

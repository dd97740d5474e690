// LiDAR measurement model: every shot is ray-cast at its own firing time from the TRUE LiDAR pose
// at that instant, T_WL(t) = T_WI(t) T_IL, and reported in the LiDAR frame of that instant (not
// deskewed). A return needs blind <= range <= max range; the measured range carries Gaussian
// noise; the beam direction jitters by a small angular noise (the point is reported along the
// nominal direction). Intensity = 255 * reflectivity * (a + (1 - a) |cos incidence|).
// With traffic, every shot is also cast against the moving objects placed at the shot's own time;
// the nearer surface wins and the point is labelled moving (1) or static (0). The noise draws do
// not depend on what is hit, so a run without traffic has the same points wherever no mover was.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "fuse/core/types.hpp"
#include "fuse/sim/lidar_pattern.hpp"
#include "fuse/sim/random.hpp"
#include "fuse/sim/traffic.hpp"
#include "fuse/sim/trajectory.hpp"
#include "fuse/sim/world.hpp"

namespace fuse::sim {

class LidarSimulator {
 public:
  /// world, trajectory and traffic (optional: no moving objects) must outlive the simulator.
  LidarSimulator(const LidarConfig& config, const World& world, const Trajectory& trajectory,
                 const Eigen::Isometry3d& T_imu_lidar, std::uint64_t seed, const Traffic* traffic = nullptr);

  /// Frame k spans [t0 + k T, t0 + (k + 1) T] (T: frame period); points in firing order.
  /// `labels`, if given, receives one label per point: 0 static world, 1 moving object.
  fuse::LidarScan scan(std::uint64_t frame_index, double t0, std::vector<std::uint8_t>* labels = nullptr);

 private:
  LidarConfig config_;
  const World& world_;
  const Trajectory& trajectory_;
  Eigen::Isometry3d T_imu_lidar_;
  Rng rng_;
  const Traffic* traffic_;
  std::vector<Shot> shots_;
  std::vector<MoverCandidate> candidates_;
};

}  // namespace fuse::sim

// Scenarios (spec "Scenarios"): a world seeded by --world-seed and a trajectory whose motion
// variations are seeded by --seed. The LiDAR-IMU extrinsic is the same for every scenario.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fuse/sim/street_traffic.hpp"
#include "fuse/sim/traffic.hpp"
#include "fuse/sim/trajectory.hpp"
#include "fuse/sim/world.hpp"

namespace fuse::sim {

/// The Livox Mid-360's IMU offset: LiDAR origin in the IMU frame (metres).
inline const Eigen::Vector3d kLidarInImuTranslation(-0.011, -0.02329, 0.04412);
/// A small LiDAR-IMU misalignment (roll, pitch, yaw in degrees; about 2 deg in total), so that
/// estimators cannot get away with assuming an identity rotation.
inline const Eigen::Vector3d kLidarInImuRpyDeg(0.8, -1.5, 1.0);
/// Scans and IMU samples start here (seconds), like the shared sample sequence.
constexpr double kStartTime = 1000.0;

/// T_imu_lidar: p_imu = R p_lidar + t.
Eigen::Isometry3d default_T_imu_lidar();

struct Scenario {
  std::string name;
  World world;
  std::optional<Trajectory> trajectory;
  /// Scenario-specific parameters for scenario.yaml (world dimensions, counts, speeds).
  std::vector<std::pair<std::string, double>> parameters;
  /// A vehicle: its IMU measures engine and road vibration (vibration.hpp).
  bool vehicle_vibration = false;
  /// Streets that can carry traffic (urban); the movers, when built with traffic.
  std::optional<StreetGrid> streets;
  std::optional<Traffic> traffic;
  TrafficStats traffic_stats;
};

/// The accepted names: corridor, stairs, room, campus, urban.
const std::vector<std::string>& scenario_names();
/// Whether the scenario has moving objects (fuse-sim --traffic): urban.
bool scenario_has_traffic(const std::string& name);

/// Builds a scenario (world built, ready to cast). Throws std::invalid_argument on an unknown name
/// or on laps > 1 for a scenario whose path is not a loop (only the corridor's is). start_at > 0
/// starts the walk that far (path parameter, metres on straight segments) along the path, at rest,
/// in the same world frame; it throws when that leaves too little path for the speed ramps.
/// traffic: a scenario with streets gets its moving objects (drawn from the world seed, kept
/// clear of this trajectory); false leaves the same static world, path and seeds without them.
/// stops > 0: a driven scenario (urban) stops that many times, at the stop line before each of
/// its first corners, for kStopDwellS (scenario_stops); others throw.
Scenario make_scenario(const std::string& name, std::uint64_t world_seed, std::uint64_t seed,
                       double t0 = kStartTime, int laps = 1, double start_at = 0.0, bool traffic = true,
                       int stops = 0);

/// s a car waits at each stop (fuse-sim --stops), and m before a corner's slow stretch it stops.
inline constexpr double kStopDwellS = 4.0;
inline constexpr double kStopLineM = 2.0;
/// Whether the scenario drives a schedule with corners to stop before (fuse-sim --stops): urban.
bool scenario_can_stop(const std::string& name);

}  // namespace fuse::sim

// The whole simulation: scenario -> IMU samples and LiDAR scans written incrementally (MCAP
// recording or sequence directory), the true IMU pose at the IMU rate (groundtruth.tum), every
// parameter used (scenario.yaml), the static / moving label of every point (point_labels.bin) and
// the moving objects (moving_objects.csv). Same options -> byte-identical files.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

namespace fuse::sim {

enum class OutputFormat { kMcap, kSeqdir };

struct SimOptions {
  std::string scenario;
  std::uint64_t seed = 0;
  std::uint64_t world_seed = 0;
  std::optional<double> duration_s;  ///< cut the scenario short (never lengthens it)
  int laps = 1;                      ///< times round a loop (corridor only)
  double start_at_m = 0.0;           ///< start this far along the path (same world and frame)
  int stops = 0;                     ///< urban: stop at the stop line before the first N corners (kStopDwellS)
  std::string lidar = "mid360";
  /// The IMU's clock against the LiDAR's: every IMU sample is stamped its true time plus this
  /// (s; the ground truth and the scans are on the LiDAR's clock, the true one). A sensor pair
  /// without hardware sync has offsets of several to tens of milliseconds.
  double imu_time_offset_s = 0.0;
  OutputFormat format = OutputFormat::kMcap;
  std::string out_dir;
  /// Moving objects in a scenario that has them (urban); false: the same run without them.
  bool traffic = true;
  /// Not empty: classify this map point cloud against the scenario's world instead of simulating
  /// (map_classifier.hpp); points within the tolerance count as on a surface.
  std::string classify_map;
  double classify_tolerance_m = 0.3;
  /// Not empty: the map is in the frame of this estimate (TUM, T_map_imu), and is moved into the
  /// world by the rigid alignment of the estimate onto the true trajectory (as fuse-eval's ATE).
  std::string map_trajectory;
};

struct SimSummary {
  std::size_t scans = 0, imu_samples = 0, points = 0;
  std::size_t moving_points = 0;  ///< points on moving objects
  double duration_s = 0.0;
  double path_length_m = 0.0;  ///< the whole scenario's path (all laps)
  double travelled_m = 0.0;    ///< what this run walked of it (less with --duration)
  double wall_time_s = 0.0;
};

/// Runs the simulation; throws std::invalid_argument / std::runtime_error with a clear message.
SimSummary run_simulation(const SimOptions& options);

}  // namespace fuse::sim

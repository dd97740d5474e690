// Single-process offline runner: feeds a recording or sequence directory through the FUSE
// Estimator in arrival order and writes the trajectory, timing and diagnostics.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "fuse/core/config.hpp"
#include "fuse/core/types.hpp"
#include "fuse/estimation/estimator.hpp"

namespace fuse {

struct RunnerConfig {
  EstimatorConfig estimator;
  /// Map files (command line, not YAML): a snapshot to start from (e.g. to localize on it with
  /// estimator.map.mode=localization) and one to write the final map to. Empty: none.
  std::string load_map, save_map;
  /// The extrinsic T_imu_lidar: "input" (a recording's calibration record or a sequence's
  /// calib.yaml, when there is one, over the config's) or "config" (the config's, always).
  std::string extrinsic_from = "input";
  /// The IMU's pose in the loaded map at the start, with its σ (--initial-pose): the search for
  /// the start is confined around it. Without it, estimator.global_localization decides.
  std::optional<InitialPose> initial_pose;
  void load(ConfigNode& root);
};

/// Loads a config file and applies "dotted.key=value" overrides (e.g. estimator.update.max_iterations=3).
RunnerConfig load_runner_config(const std::string& file, const std::vector<std::string>& overrides = {});

struct RunSummary {
  std::size_t scans = 0, scans_updated = 0, imu_samples = 0;
  /// Points left out as moving (estimator.map.carve_lookback_s) and map points carved (carve_s),
  /// over the run.
  std::size_t moving_screened = 0, map_carved = 0;
  bool initialised = false;
  std::vector<double> scan_ms;  ///< total per-scan estimator time
  double mean_ms = 0.0, p95_ms = 0.0, max_ms = 0.0;
  std::vector<double> scan_cpu_ms;  ///< the processing thread's CPU time per scan
  double cpu_median_ms = 0.0, cpu_p99_ms = 0.0, cpu_max_ms = 0.0;
  std::vector<StampedPose> trajectory;      ///< IMU pose at scan end times
  std::vector<StampedPose> trajectory_imu;  ///< IMU pose at IMU rate (causal estimate)
  std::map<std::string, std::uint64_t> input_rejected;    ///< from the sensor source
  std::map<std::string, std::uint64_t> estimator_counts;  ///< from the estimator
  /// Tracking status at the end of the run, why, and every stretch spent relocalizing or lost.
  TrackingStatus tracking = TrackingStatus::kTracking;
  std::string tracking_reason;
  std::vector<TrackingMonitor::Episode> episodes;
  double relocalizing_s = 0.0, lost_s = 0.0;
  /// With a loaded map searched for the start: whether and when the run found itself in it, the
  /// searches it took, and the last search's verdict. Poses before that are written in the map's
  /// frame once it is found (the session's own odometry moved by T_M_S), and not at all if never.
  bool searched_map = false, localized = false;
  double localized_t = 0.0, localized_after_s = 0.0;
  std::size_t searches = 0;
  double search_s = 0.0;          ///< wall time of the searches (a thread of their own unless blocking)
  std::string localization;       ///< MapLocalization::describe at the end
  bool initial_pose_refused = false;
  /// The LiDAR-IMU time offset at the end (s, t_imu = t_lidar + it): estimator.time_offset's
  /// initial_s, or its estimate when estimated.
  double time_offset = 0.0;
  /// The extrinsic T_imu_lidar at the end (p_imu = R_IL·p_lidar + p_IL): the one given, or its
  /// estimate with estimator.estimate_extrinsic.
  Eigen::Matrix3d R_IL = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p_IL = Eigen::Vector3d::Zero();
  /// The run diverged by a measure computable without truth (DivergenceError, lost at the end or
  /// for longer than estimator.tracking.max_lost_s): fuse-run exits 3.
  bool diverged = false;
  std::string divergence;  ///< why it diverged
  std::string error;       ///< why the run stopped early
};

/// Makes sure `out_dir` exists and is a writable directory; the reason it is not, else empty.
std::string prepare_output_dir(const std::string& out_dir);

/// Runs the estimator over `input`; writes DIR/{trajectory.tum, trajectory_imu.tum, timing.csv,
/// diagnostics.csv} when out_dir is not empty. Input errors and a DivergenceError end the run with
/// summary.error set (never an exception); a lost track sets summary.diverged.
RunSummary run_offline(const RunnerConfig& config, const std::string& input, const std::string& out_dir);

}  // namespace fuse

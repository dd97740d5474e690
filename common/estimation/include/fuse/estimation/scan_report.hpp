// What one LiDAR step did (LidarUpdater::process): written by the runner to timing.csv /
// diagnostics.csv, and what a TrackingMonitor judges the track by.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>

namespace fuse {

/// How much of the extrinsic's estimate a scan's update held (estimator.extrinsic_excitation);
/// the values are diagnostics.csv's ext_held column.
enum class ExtrinsicHold : int {
  kNone = 0,  ///< estimated (or not estimated at all: estimate_extrinsic false)
  kAll = 1,   ///< held whole: the motion turns too little about its weakest axis
  kTilt = 2,  ///< held but for the tilt against the one axis the motion turns about (one_axis: tilt)
};

/// Per-scan diagnostics and timing.
struct ScanReport {
  double t = 0.0;
  std::uint64_t sequence = 0;
  bool updated = false;
  std::size_t points_in = 0, points_kept = 0;
  std::size_t constraints = 0, rejected_no_neighbors = 0, rejected_not_planar = 0, rejected_screening = 0;
  int iterations = 0;
  bool converged = false;
  /// The scan's IMU samples said the sensor rests: v = 0 was measured at its end (estimator.zero_velocity).
  bool at_rest = false;
  bool recovery = false;  ///< the prior was uncertain: re-localised (estimator.recovery)
  /// The re-localisation was ambiguous (recovery.ambiguity_*): it turned away from the prior's
  /// heading, and a result rival_heading (rad, about gravity) from the kept one fitted rival_fit,
  /// nearly as well.
  bool ambiguous = false;
  double rival_fit = 0.0, rival_heading = 0.0;
  /// 1 − mean truncated residual cost (min(r², τ²)/τ², τ = recovery.inlier_residual) of the scan's
  /// kept points at the posterior (a point without a plane costs 1); every updated scan.
  double fit = 0.0;
  /// The same over the points that have a constraint only: how well the matched points lie on
  /// their planes, whatever share of the scan found a plane (an open scene leaves many without).
  double match_fit = 0.0;
  double time_offset = 0.0;     ///< s: the LiDAR-IMU time offset after the update (t_imu = t_lidar + it)
  double prior_position_std = 0.0;  ///< m: largest σ of the prior position at the scan end
  double prior_rotation_std = 0.0;  ///< rad: largest σ of the prior rotation
  double min_eig_translation = 0.0, min_eig_rotation = 0.0, min_gamma = 1.0, min_eig_ratio = 1.0;
  std::size_t map_points = 0, map_inserted = 0;
  /// New points not mapped yet: their place has not persisted for map.confirm_s (a moving object,
  /// or space seen for the first time).
  std::size_t map_pending = 0;
  /// The extrinsic T_imu_lidar after this scan: rotation vector (rad) and translation (m), and
  /// how much of its estimate was held for weak excitation (estimator.extrinsic_excitation).
  Eigen::Vector3d extrinsic_rotation = Eigen::Vector3d::Zero();
  Eigen::Vector3d extrinsic_translation = Eigen::Vector3d::Zero();
  ExtrinsicHold extrinsic_held = ExtrinsicHold::kNone;
  std::size_t map_carved = 0;   ///< map points a ray of this scan showed empty (free-space carving)
  std::size_t moving_screened = 0;  ///< points where an earlier scan saw empty space: left out of the update and the map
  /// Map hold: re-localised, or within recovery.map_hold_distance after it; only the points
  /// within recovery.map_hold_radius of the sensor were offered to the map.
  bool map_held = false;
  /// This scan's contribution to the uncertainty of the map frame itself, in the world frame and
  /// block-diagonal (position; rotation as a world-frame perturbation): f·P with f the fraction of
  /// its points that went into the map. The filter's P is relative to the map, and newly mapped
  /// space inherits the pose's error (see LidarUpdater::process). Zero when nothing was mapped.
  Eigen::Matrix<double, 6, 6> map_drift = Eigen::Matrix<double, 6, 6>::Zero();
  double ms_deskew = 0.0, ms_association = 0.0, ms_update = 0.0, ms_map = 0.0, ms_total = 0.0;
  /// Full searches of the map this scan's update made (the first association and each
  /// re-association; re-localisation counts all its hypotheses): what ms_association scales with.
  int map_searches = 0;
  /// CPU time of the processing thread over the whole step (ms): the wall time above less what
  /// the machine spent elsewhere; the per-scan tail is judged on it.
  double ms_cpu = 0.0;
  /// Page faults the processing thread took over the step: memory touched for the first time
  /// (a growing buffer, a fresh allocation), the usual cause of a scan far slower than its peers.
  std::uint64_t page_faults = 0;
};

}  // namespace fuse

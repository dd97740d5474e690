// Configuration of the FUSE LiDAR-inertial estimator: one struct per module, the whole read
// from the `estimator` section of a config file.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include "fuse/association/associator.hpp"
#include "fuse/association/spatial_index.hpp"
#include "fuse/core/config.hpp"
#include "fuse/core/time_gate.hpp"
#include "fuse/estimation/excitation_monitor.hpp"
#include "fuse/estimation/global_localizer.hpp"
#include "fuse/estimation/imu_propagation.hpp"
#include "fuse/estimation/point_to_plane_model.hpp"
#include "fuse/estimation/state_history.hpp"
#include "fuse/estimation/static_initializer.hpp"
#include "fuse/estimation/tracking_monitor.hpp"
#include "fuse/estimation/update_backend.hpp"
#include "fuse/estimation/zero_velocity.hpp"
#include "fuse/map/map_policy.hpp"

namespace fuse {

/// The filter can no longer be trusted (NaN, covariance blow-up, no constraints for too long).
class DivergenceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct PreprocessConfig {
  double min_range = 0.5;    ///< m: closer returns (the sensor's blind zone, the carrier) are dropped
  double max_range = 60.0;   ///< m
  double voxel_size = 0.5;   ///< m: downsampling before deskew and association
  /// Cap on the points kept per scan: when the voxel filter keeps more, the voxel is enlarged
  /// (by √(kept/max), up to kMaxVoxelGrowth times) so the per-scan cost stays bounded on dense
  /// or open scenes whatever the sensor.
  std::size_t max_points = 3000;
  bool deskew = true;        ///< ablation switch
  void load(ConfigNode& node);
  /// Step 1's range filter: a finite point between min_range and max_range.
  struct RangeGate {
    float min2, max2;  ///< squared bounds, m²
    /// A NaN or infinite coordinate fails both comparisons.
    bool pass(const Eigen::Vector3f& v) const {
      const float r2 = v.squaredNorm();
      return r2 >= min2 && r2 <= max2;
    }
  };
  /// Taken once per scan: its bounds are not recomputed per point.
  RangeGate range_gate() const {
    return RangeGate{static_cast<float>(min_range * min_range), static_cast<float>(max_range * max_range)};
  }
};

struct InitialCovarianceConfig {
  double position_std = 1e-3;        ///< m
  double roll_pitch_std = 0.02;      ///< rad
  double yaw_std = 1e-3;             ///< rad
  double velocity_std = 0.01;        ///< m/s (starts at rest)
  double gyro_bias_std = 0.005;      ///< rad/s
  double accel_bias_std = 0.1;       ///< m/s²
  double extrinsic_rotation_std = 0.01;     ///< rad, when estimated
  double extrinsic_translation_std = 0.01;  ///< m, when estimated
  double gravity_std = 0.01;         ///< rad, when estimated
  void load(ConfigNode& node);
};

struct DivergenceConfig {
  double max_position_std = 50.0;       ///< m: larger means the filter lost track
  int max_scans_without_constraints = 50;
  double max_imu_gap = 0.1;             ///< s: a larger gap between IMU samples is flagged (data gap)
  /// Unmodelled motion across a data gap of length Δt (nothing measured it): the covariance grows
  /// by (½σ_a Δt²)² in position, (σ_a Δt)² in velocity and (σ_ω Δt)² in rotation, so the LiDAR
  /// updates after the gap may pull the state back instead of trusting the coasted prediction.
  double gap_accel_std = 1.0;           ///< σ_a, m/s²
  double gap_gyro_std = 0.5;            ///< σ_ω, rad/s
  /// s: the gap length whose covariance a prior of unknown age gets (after a clock step, or a lost
  /// track widened for re-localisation): nothing says how far it moved, only the map can.
  double unknown_gap_s = 2.0;
  /// s: the gap is coasted at the rotation rate that the mean rate over this window before it and
  /// the first sample after it agree on (StateTracker, agreed_rate); one period of the slowest
  /// oscillation expected (handheld sway, gait) averages it out.
  double gap_rate_window = 1.0;
  /// Level the coasted attitude with the first accelerometer sample after the gap: a gravity
  /// direction update with noise σ_a/|g| (level_with_accelerometer). A handheld sensor sways by
  /// tens of degrees of roll and pitch within a gap that no rate before or after it tells.
  bool gap_level = true;
  /// A scan that ends more than max_imu_gap after the newest IMU sample (the IMU silent while the
  /// LiDAR runs: a dropout, a burst of NaN samples) coasts the history to its end as across a data
  /// gap (StateTracker::coast_to), so that the scan is re-localised against the map. false: the
  /// history is extrapolated with the held IMU measurement and a tight covariance (a negative
  /// control: the scans cannot pull the state back).
  bool coast_silent_imu = true;
  void load(ConfigNode& node);
};

/// Re-localisation when the prior no longer predicts the scan well: after a data gap (its covariance
/// grown by the unmodelled motion), or a state restored or initialised without recent LiDAR. Such a
/// prior is off by decimetres or degrees, so the residuals of correct matches are far beyond the
/// normal screening gates (|r| ≤ max_residual, match quality), and the iterated update needs more
/// than the usual few iterations and map searches to walk back into the map. For a scan whose
/// prior pose σ exceeds a threshold, the update runs without residual screening and with the caps
/// below; if it still does not converge, the scan is not offered to the map (a misplaced scan in
/// the map would pull every later one towards it). Normal scans (prior σ of millimetres) never
/// take this path.
struct RecoveryConfig {
  bool enabled = true;
  double position_std = 0.05;       ///< m: largest position σ of the prior above which a scan is re-localised ...
  double rotation_std = 0.05;       ///< rad: ... or largest rotation σ above which
  int max_iterations = 20;          ///< update iterations of such a scan (iterated backends: ieskf, nano)
  int reassociate_iterations = 15;  ///< iterations of it that may search the map again
  /// Heading search: a gap can hide a turn that no rotation rate before or after it tells (a
  /// handheld sensor turns at up to ~150°/s), so the coasted heading may be off by anything. Such
  /// a scan is re-localised from this many headings about the gravity axis, evenly spaced around
  /// the prior's (1: the prior's only), and the most probable result is kept
  /// (LidarUpdater::relocalise: truncated residual cost plus the prior's pose term). Only when
  /// the prior's heading σ is at least π/(3K): a narrower one is searched from itself alone.
  int heading_hypotheses = 12;
  /// After a coasted gap, a heading hypothesis is a turn taken during the gap: its position is
  /// moved to the end of the arc that turn would have followed, and its velocity turned alike
  /// (LidarUpdater::turned). false: every hypothesis turns about the coasted position.
  bool turn_through_gap = true;
  /// m: τ, a point's residual cost is min(r², τ²)/σ² (farther is an outlier, as is a point
  /// without a plane); the fit of a result is 1 − the mean of min(r², τ²)/τ².
  double inlier_residual = 0.1;
  /// Another heading's result replaces the prior's only if its cost is lower by this fraction of
  /// the scan's points turned into outliers (a symmetric place such as a straight corridor fits
  /// its mirror image almost as well as itself; the prior decides such ties).
  double heading_margin = 0.02;
  /// A re-localised scan whose fit is below this is not offered to the map (nor is one that did
  /// not converge): a misplaced scan in the map would pull every later one towards it.
  double min_fit = 0.5;
  /// A re-localisation whose best result fits worse than this is not taken at all (the history
  /// keeps the uncertain prior and the next scan searches again): a fit of a few percent is no
  /// location, and taking it moves a usable prior far off. Right headings after a gap across a
  /// turn have fitted as poorly as 0.39 and were worth taking (docs/chaos.md).
  double commit_fit = 0.2;
  /// A scan of which less than this fraction of the in-range points was measured after a data gap
  /// (the rest is cut: nothing measured the motion that would deskew them) is not re-localised:
  /// what is left is a sliver of the scene, and it fits a wrong place as well as the right one (a
  /// restarted driver's first scan ends 1 ms after the IMU resumes: 161 constraints instead of
  /// 1,800, fit 0.95, 4 m along the corridor). The prior stays and the next scan, measured whole,
  /// searches.
  double min_measured_fraction = 0.5;
  /// A re-localisation is ambiguous when its kept result's heading ended more than
  /// ambiguity_angle (rad) from the prior's, while a result whose heading ended more than
  /// ambiguity_angle from the kept one fits within ambiguity_fit of it: a young map that sees only
  /// the way back, or a symmetric place, can fit a mirror image better than the truth. It is taken
  /// all the same but counted (recovery_ambiguous), logged with both fits, flagged in the scan
  /// report and summarised by fuse-run and fuse-launch: a warning, not a verdict (a handheld sensor
  /// that turned through a gap in a box-shaped room gives it too; docs/chaos.md has the figures).
  /// A mirror image that fits as well as a result keeping the prior's heading is the normal case
  /// in a corridor (the prior decides) and is not flagged.
  double ambiguity_angle = 1.0471975511965976;  // 60°
  double ambiguity_fit = 0.1;
  /// m: a re-localised scan, and every scan until the vehicle has moved this far from it, offers
  /// the map only its points within map_hold_radius of the sensor. A re-localisation settles over
  /// a few scans, and one that settled a little off (along a corridor, tilted after a gap across a
  /// turn) would otherwise be written into the space ahead and never corrected: later scans fit
  /// it. By distance, not time: a fast vehicle must not run off its map. 0: off.
  /// Figures: docs/chaos.md, "Map hold after a re-localisation".
  double map_hold_distance = 2.5;
  /// m: during the hold, points nearer the sensor than this are still added: later scans need the
  /// map dense where they are (held back entirely, a young map starves and the estimate slides),
  /// and a small rotation error moves near points little.
  double map_hold_radius = 8.0;
  void load(ConfigNode& node);
};

/// The LiDAR-IMU time offset t_d (t_imu = t_lidar + t_d): a sensor pair without hardware sync
/// stamps its scans and IMU samples on two clocks. Scans are placed at their stamp plus the
/// current estimate; estimated, it is part of the state with its own covariance.
struct TimeOffsetConfig {
  double initial_s = 0.0;      ///< the offset assumed at the start (s)
  bool estimate = true;        ///< estimate it online (false: initial_s stays)
  double std_s = 0.02;         ///< prior σ when estimated (s)
  double max_s = 0.1;          ///< bound: an estimate beyond ±max_s is held at it and counted
  double random_walk = 1e-4;   ///< s/√s: how fast the offset may drift (clock drift, jitter)
  /// For this long after a re-localisation the offset is held (the scans update everything
  /// else): a re-localised attitude is more confident than right, and the offset's coupling to
  /// the attitude would take up the difference (docs/architecture.md, "Across an IMU dropout").
  double hold_after_relocalisation_s = 1.0;
  /// s: time constant of the low-pass of the gyro readings whose change ties the offset to the
  /// attitude (StateHistory::Entry::gyro_smooth): the offset is seen in how the rate averaged
  /// over tens of milliseconds changes, not in vibration faster than that. 0: raw readings.
  double rate_smoothing_s = 0.0;
  void load(ConfigNode& node);
};

struct EstimatorConfig {
  double gravity_magnitude = 9.81;
  bool estimate_extrinsic = false;
  /// With estimate_extrinsic: the extrinsic is held while the motion does not turn about every
  /// axis (excitation_monitor.hpp).
  ExcitationConfig extrinsic_excitation;
  bool estimate_gravity = true;   ///< gravity direction in the map frame (2-D, on S²); false: fixed at initialisation
  Eigen::Isometry3d T_imu_lidar = Eigen::Isometry3d::Identity();
  StaticInitConfig init;
  ImuNoiseConfig imu;
  StateHistoryConfig history;
  PreprocessConfig preprocess;
  AssociationConfig association;
  PointToPlaneModel::Config measurement;
  UpdateConfig update;
  SpatialIndexConfig index;
  MapPolicyConfig map;
  InitialCovarianceConfig initial_covariance;
  TimeOffsetConfig time_offset;
  ZeroVelocityConfig zero_velocity;  ///< a scan whose IMU says the sensor is at rest updates v = 0
  DivergenceConfig divergence;
  RecoveryConfig recovery;
  TimeGateConfig clock;      ///< time checks of the IMU and scan streams
  TrackingConfig tracking;   ///< tracking / relocalizing / lost
  GlobalLocalizationConfig global_localization;  ///< finding the start in a saved map
  /// Reads the `estimator` section of a config file (unknown keys are refused).
  void load(ConfigNode& node);
};

}  // namespace fuse

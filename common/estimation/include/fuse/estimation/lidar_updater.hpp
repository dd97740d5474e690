// Spatial + inference + functional side of one LiDAR step (DESIGN §1), given a state history
// that holds an entry at the scan end:
//   1. range filter + voxel downsample the raw points
//   2. deskew each kept point through the history                 (temporal query)
//   3. associate against the map, screen, update at t_e           (spatial + inference)
//      and correct the history there
//   4. offer the world-frame points to the map policy             (functional)
// The single-process Estimator runs it on its own history; the fuse-update service runs it on
// the slice of history it receives from fuse-state, and sends the posterior back.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fuse/association/associator.hpp"
#include "fuse/association/spatial_index.hpp"
#include "fuse/association/voxel_filter.hpp"
#include "fuse/core/counters.hpp"
#include "fuse/core/types.hpp"
#include "fuse/estimation/deskew.hpp"
#include "fuse/estimation/excitation_monitor.hpp"
#include "fuse/estimation/estimator_config.hpp"
#include "fuse/estimation/scan_report.hpp"
#include "fuse/estimation/state_history.hpp"
#include "fuse/estimation/update_backend.hpp"
#include "fuse/map/map_policy.hpp"

namespace fuse {

class LidarUpdater {
 public:
  explicit LidarUpdater(const EstimatorConfig& config);

  /// Runs steps 1–4 for a scan; `history` must hold an entry at scan.t_end (ensure_entry). The
  /// posterior is written into `history` at t_end. Throws DivergenceError.
  ScanReport process(const LidarScan& scan, StateHistory& history);
  /// Γ_k: posterior update at time t with a measurement model, correcting the history at t.
  UpdateResult update(MeasurementModel& model, StateHistory& history, double t);
  /// True when the prior at a scan is uncertain enough to re-localise (estimator.recovery).
  bool needs_recovery(const StateCovariance& P) const;

  /// World-frame points of the last processed scan at its posterior (the accepted observation
  /// offered to the map; empty when a re-localisation did not converge) and the pose they were placed with.
  const std::vector<Eigen::Vector3f>& last_world_points() const { return points_W_; }
  const Eigen::Isometry3d& last_T_world_lidar() const { return T_WL_; }
  /// The last processed scan's points, deskewed and downsampled, in the LiDAR frame at its end
  /// (last_T_world_lidar() places them); empty when it had none. For viewers: every point, held or not.
  const std::vector<Eigen::Vector3f>& last_scan_points() const { return points_L_; }

  SpatialIndex& map() { return *map_; }
  /// Starts over with an empty map (a replica about to be rebuilt from the map server).
  void reset_map() { map_ = make_spatial_index(config_.index); }
  const SpatialIndex& map() const { return *map_; }
  /// Starts over on these world-frame points with this map mode (a session moving into a saved
  /// map's frame, or back out of it): nothing of the previous map or its hold is kept.
  void restart_map(const std::vector<Eigen::Vector3f>& points, const std::string& mode) {
    reset_map();
    map_->insert(points);
    set_map_mode(mode);
    hold_from_.reset();
    scans_without_constraints_ = 0;
  }
  /// Replaces the map policy at run time (mapping | localization).
  void set_map_mode(const std::string& mode);
  std::string map_mode() const { return map_policy_->name(); }
  Counters& counters() { return counters_; }
  const Counters& counters() const { return counters_; }

  /// Positions bounding a coasted data gap: where the coasting started and where it ended.
  struct CoastedGap {
    Eigen::Vector3d p_start, p_end;
  };
  /// The latest coasted gap in `history` between its last correction and t, if any.
  static std::optional<CoastedGap> coasted_gap(const StateHistory& history, double t);
  /// A re-localisation's heading hypothesis ψ (rad, about `up`): the prior turned by ψ, as a
  /// constant-rate turn through `gap` when there is one (recovery.turn_through_gap).
  static NavState turned(const NavState& prior, const std::optional<CoastedGap>& gap, double psi, const Eigen::Vector3d& up);

 private:
  /// estimator.zero_velocity: when the scan's IMU samples say the sensor rests, corrects the
  /// history at the scan end with v = 0 (zero_velocity.hpp) and flags the report.
  void hold_still(const LidarScan& scan, StateHistory& history, ScanReport& report);
  void downsample();
  /// Drops the scan's points that the map policy marks as moving (mark_moving, at the prior).
  void screen_moving(const NavState& prior, ScanReport& report);
  void order_spatially();
  void check_divergence(const ScanReport& report, const StateHistory& history);
  /// Truncated residual cost of the scan's kept points against their constraints at x (below).
  double truncated_cost(const NavState& x) const;
  /// The fit (ScanReport::fit) of a truncated cost.
  double fit_of(double cost) const;
  /// ScanReport::match_fit at x: 1 − (1/M) Σ_j min(r_j², τ²)/τ² over the M constrained points.
  double match_fit(const NavState& x) const;
  /// Re-localises the scan at t from several headings and keeps the best fit (recovery.heading_*);
  /// corrects the history at t and fills the report's update fields.
  UpdateResult relocalise(StateHistory& history, double t, ScanReport& report);
  /// recovery.map_hold_distance: whether this scan (at posterior x) offers the map only its points
  /// within recovery.map_hold_radius.
  bool holds_map(const ScanReport& report, const NavState& x);

  EstimatorConfig config_;
  std::unique_ptr<SpatialIndex> map_;
  std::unique_ptr<UpdateBackend> backend_;
  std::unique_ptr<UpdateBackend> recovery_backend_;  ///< the backend with estimator.recovery's caps
  std::unique_ptr<MapPolicy> map_policy_;
  Associator associator_;
  Associator recovery_associator_;  ///< without residual screening
  PointToPlaneModel::Config recovery_measurement_;
  VoxelFilter voxel_filter_;
  float voxel_size_;  ///< downsampling voxel in use (adapts to max_points)
  Deskewer deskewer_;
  int scans_without_constraints_ = 0;
  /// When the last re-localisation was taken: the time offset is held for a while after it.
  double relocalised_at_ = -std::numeric_limits<double>::infinity();
  ExcitationMonitor excitation_;  ///< whether the motion lets the extrinsic be estimated
  ExtrinsicHold last_extrinsic_hold_ = ExtrinsicHold::kNone;
  /// World position of the last re-localised scan while its map hold lasts (recovery.map_hold_distance).
  std::optional<Eigen::Vector3d> hold_from_;
  Counters counters_;
  Eigen::Isometry3d T_WL_ = Eigen::Isometry3d::Identity();
  // Per-scan buffers reused to avoid allocation on the hot path.
  std::vector<Eigen::Vector3f> raw_, points_L_, points_W_;
  std::vector<Eigen::Vector3f> origins_L_, origins_W_;  ///< where each point's ray started (deskew)
  std::vector<std::uint8_t> moving_;  ///< per point: where an earlier scan saw empty space
  std::vector<std::uint32_t> in_range_, kept_, kept_raw_;
  std::vector<std::uint64_t> keyed_, sorted_;  ///< Morton code << 32 | point index (order_spatially)
  ConstraintSet constraints_;
  ConstraintSet best_constraints_;  ///< the heading search's best hypothesis so far
};

}  // namespace fuse

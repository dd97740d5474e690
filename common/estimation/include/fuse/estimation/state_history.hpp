// Temporal role (DESIGN §1): a bounded time history of (t, x, P) written by IMU propagation.
// Any time it covers can be queried (interpolated on the manifold); a posterior at a past time
// replaces the entry there and every later entry is re-propagated from the stored IMU samples.
//
// Re-propagation is lazy: a correction (or a split) marks the entries after it stale, and they
// are recomputed, in order and by the same formula, when something reads them. The numbers are
// the same as if it were done at once; what changes is that a run of corrections far in the past
// (fuse-state catching up on scans held during its restart) re-propagates the tail once, not once
// per correction (~60 ms for 40 s of 200 Hz IMU). New IMU samples are propagated at once while
// the stale tail is short (kEagerRefresh entries: the normal case) and appended stale otherwise.
//
// What is not IMU propagation but belongs to a step (a coasted data gap's unmodelled motion and
// its accelerometer levelling, a prior widened for re-localisation) is kept with the entry it
// applies to (Entry::step) and applied again whenever the entry is recomputed: a correction
// older than a coasted gap (a held scan answered after the IMU resumed) must not re-propagate
// across the gap as if the motion during it had been measured.
#pragma once

#include <algorithm>
#include <deque>
#include <limits>
#include <vector>

#include "fuse/core/config.hpp"
#include "fuse/core/types.hpp"
#include "fuse/estimation/imu_propagation.hpp"
#include "fuse/estimation/state.hpp"

namespace fuse {

enum class QueryStatus {
  kNotInitialised,  ///< no state yet (static initialisation not finished)
  kCorrected,       ///< at or before the last LiDAR correction: interpolated in corrected history
  kPropagated,      ///< after the last correction, up to the newest IMU sample: IMU-only prediction
  kTooOld,          ///< before the oldest entry kept
  kInFuture,        ///< after the newest IMU sample
};
const char* to_string(QueryStatus status);

struct StateQuery {
  QueryStatus status = QueryStatus::kNotInitialised;
  double t = 0.0;
  NavState x;
  StateCovariance P = StateCovariance::Zero();
  /// Angular velocity of the IMU body (IMU frame, rad/s): the gyro sample held at t minus the
  /// gyro bias, ω = ω̃ − b_g: the rate the propagation integrates at t.
  Eigen::Vector3d omega = Eigen::Vector3d::Zero();
  bool ok() const { return status == QueryStatus::kCorrected || status == QueryStatus::kPropagated; }
};

/// The IMU measurement of a sensor at rest in state x, at time t: ω̃ = b_g and f = R⊤(−g) + b_a
/// (a zero reading would be a rotation of −b_g).
inline ImuSample rest_measurement(const NavState& x, double t) {
  ImuSample m;
  m.t = t;
  m.gyro = x.bg;
  m.accel = x.R.transpose() * (-x.g) + x.ba;
  return m;
}

struct StateHistoryConfig {
  double length_s = 5.0;  ///< how far back states are kept (late scans older than this are refused)
  void load(ConfigNode& node);
};

/// Gravity-direction update from one accelerometer sample: the bias-free specific force f (IMU
/// frame) of a sensor that is not accelerating points up, f/|f| = R_WIᵀu with u = −g/|g|. An
/// iterated EKF update of (x, P) with that measurement and noise σ² I₃ (σ in rad; σ_a/|g| for an
/// unmodelled acceleration σ_a) corrects roll and pitch (and what correlates with them); the
/// heading is unobservable from it and stays.
void level_with_accelerometer(const Eigen::Vector3d& f, double sigma, NavState& x, StateCovariance& P);

/// Variance of the motion nobody measured over dt (a coasted data gap): an unknown constant
/// acceleration of σ_a per axis, δp = ½σ_a·dt², δv = σ_a·dt, and an unknown rate of σ_ω, δθ = σ_ω·dt.
StateVector unmodelled_motion_variance(double accel_std, double gyro_std, double dt);

/// What happens on arriving at an entry besides IMU propagation: P += diag(q) + the unmodelled
/// motion of a coasted step, then (when level_sigma > 0) level_with_accelerometer(level_accel −
/// b_a, level_sigma).
///
/// The unmodelled motion is counted from the coast's anchor (`coast_from`: where the coast
/// started, or the latest correction inside it): the step from t_prev to t adds V(t − a) −
/// V(t_prev − a), V = unmodelled_motion_variance. Steps that split a coast add up to the whole
/// coast's V, and a correction inside it (a held scan answered after the IMU resumed) restarts
/// the count there: the rest of the gap is as uncertain as its own length makes it, not as the
/// whole gap (StateHistory::correct moves the anchor).
struct EntryStep {
  StateVector q = StateVector::Zero();               ///< diagonal covariance added (unmodelled motion)
  Eigen::Vector3d level_accel = Eigen::Vector3d::Zero();  ///< raw accelerometer sample that levels
  double level_sigma = 0.0;                          ///< rad; 0: no levelling
  double coast_from = 0.0;       ///< the coast's anchor (s); used when coast_accel_std or _gyro_std > 0
  double coast_accel_std = 0.0;  ///< m/s²: σ_a of unmodelled_motion_variance; 0 with 0 below: no coast
  double coast_gyro_std = 0.0;   ///< rad/s: σ_ω
  bool coasts() const { return coast_accel_std > 0.0 || coast_gyro_std > 0.0; }
  /// Takes `other`'s coast (anchor and deviations), keeping this step's q and levelling.
  void take_coast(const EntryStep& other) {
    coast_from = other.coast_from;
    coast_accel_std = other.coast_accel_std;
    coast_gyro_std = other.coast_gyro_std;
  }
  bool empty() const { return level_sigma <= 0.0 && (q.array() == 0.0).all() && !coasts(); }
  /// The unmodelled motion of the step from t_prev to t (zero when it does not coast).
  StateVector coast_variance(double t_prev, double t) const;
  void apply(NavState& x, StateCovariance& P, double t_prev, double t) const;
};

class StateHistory {
 public:
  struct Entry {
    double t;
    NavState x;
    StateCovariance P;
    Eigen::Vector3d gyro, accel;  ///< the IMU measurement held from t on
    EntryStep step;               ///< applied after propagating into this entry (empty: none)
    /// The step from this entry on coasts a data gap: its specific force is the one that cancels
    /// gravity in this entry's attitude, computed whenever the step is propagated (so that a
    /// correction before the gap coasts from the corrected attitude), not the held `accel`.
    bool coasting = false;
    /// The gyro readings up to this entry's, low-passed with time constant τ
    /// (ImuNoiseConfig::time_offset_rate_smoothing_s), s_k = s_{k−1} + (1 − e^{−Δt/τ})(ω̃_k − s_{k−1}):
    /// the rate whose change across a step ties the time offset to the attitude. An offset error
    /// e shifts the rate integrated over a step by e times the change of the rate *averaged over
    /// e*, not of the instantaneous rate: engine vibration at 25–40 Hz changes the raw reading
    /// from sample to sample, but a shift of tens of milliseconds averages it out
    /// (docs/architecture.md, "LiDAR-IMU time offset"). τ = 0: the raw reading.
    Eigen::Vector3d gyro_smooth = Eigen::Vector3d::Zero();
  };

  StateHistory(const StateHistoryConfig& config, const ImuNoiseConfig& noise) : config_(config), noise_(noise) {}

  /// Starts the history at time t. A static initialisation result passes the time of the sample
  /// before the initialising one (`rest_since` < t): the sensor rested over [rest_since, t], and
  /// ensure_entry answers for times in it (a scan that ends just before the initialising sample,
  /// as a ROS 2 cloud ends at its last point). Earlier scans stay before the initialisation, so
  /// a scan handed in late is treated as it would have been on time.
  void reset(double t, const NavState& x, const StateCovariance& P, const ImuSample& held,
             double rest_since = std::numeric_limits<double>::quiet_NaN());
  bool initialised() const { return !entries_.empty(); }
  /// Replaces the history by `entries` (sorted by time, not empty): a slice received from the
  /// process that owns the history (fuse-update runs the LiDAR step on it).
  void assign(const std::vector<Entry>& entries, double last_correction_t);

  /// Propagates the newest entry to imu.t with the average of the held and the new measurement.
  void add_imu(const ImuSample& imu);
  /// The step from the newest entry on coasts a data gap (Entry::coasting); a later add_imu at
  /// the same instant (a real sample) ends it.
  void mark_newest_coasting();
  /// Applies `step` to the newest entry and keeps it there (a data gap's unmodelled motion and
  /// levelling), so that a re-propagation from an older correction applies it again. A coast in
  /// `step` replaces the entry's (one coast per step).
  void add_step_to_newest(const EntryStep& step);
  /// Makes sure an entry exists at time t (t ≥ oldest; past the newest it extrapolates with the
  /// held measurement; inside a coasted step it takes the coast's unmodelled motion up to t;
  /// before the oldest, within the rest the history started from, it is the
  /// oldest state at rest). Returns false when t is older than the history.
  bool ensure_entry(double t);
  /// Replaces the entry at t (which must exist, see ensure_entry) and re-propagates later entries.
  /// A coast that spans t counts its unmodelled motion from t on (EntryStep). When x changes the time offset t_d, the later entries (IMU samples placed with the old one)
  /// move by −Δt_d; any that would reach t are dropped.
  void correct(double t, const NavState& x, const StateCovariance& P);
  /// Stale entries are recomputed when read; below this many, new samples refresh them at once.
  static constexpr std::size_t kEagerRefresh = 64;
  /// Adds diag(q) to the covariance of the entry at t (which must exist) and re-propagates later
  /// entries, without making it a correction (a lost track's prior widened for re-localisation);
  /// kept as part of the entry's step.
  void inflate(double t, const StateVector& q);

  StateQuery query(double t) const;
  /// Moves every entry into another world frame, x ← T_new_old ⊕ x (a session that found itself in
  /// a saved map: MapLocalization). T's rotation must turn about the vertical (z), up to a small
  /// tilt (the two frames' levelling).
  void transform_world(const Eigen::Isometry3d& T_new_old);
  /// The end of the latest step between consecutive entries that is longer than max_step (coasted
  /// across a data gap: nothing measured the motion) and ends in (t0, t1) where the IMU resumed;
  /// t0 when there is none. Motion from before that time to t1 is not known. A step that ends at
  /// t1 itself (a scan inside a coasted step: StateTracker::coast_to) does not count: the scan is
  /// deskewed at the constant velocity it was coasted with.
  double measured_since(double t0, double t1, double max_step) const;
  /// Entries with t0 ≤ t ≤ t1 (the caller interpolates between them).
  std::vector<const Entry*> entries_between(double t0, double t1) const;
  /// The entries whose held interval [t_i, t_i+1) meets [t0, t1]: the last one at or before t0
  /// (the oldest when none is), then every one up to t1.
  std::vector<const Entry*> entries_covering(double t0, double t1) const;

  const Entry& newest() const {
    refresh_to(entries_.size() - 1);
    return entries_.back();
  }
  double newest_time() const { return entries_.back().t; }
  /// The LiDAR-IMU time offset in force: the newest up-to-date entry's (propagation keeps it, so
  /// later entries get the same once recomputed). No re-propagation: read for every IMU sample.
  double time_offset() const { return entries_[stale_from_ - 1].x.td; }
  double oldest_time() const { return entries_.front().t; }
  double last_correction_time() const { return last_correction_t_; }
  std::size_t size() const { return entries_.size(); }
  /// Entries not yet re-propagated after a past correction (0 in the normal, eager case).
  std::size_t stale_entries() const { return entries_.size() - stale_from_; }
  /// Time of the newest entry that is up to date (what can be read without re-propagating).
  double fresh_time() const { return entries_[stale_from_ - 1].t; }

 private:
  std::size_t find_at_or_before(double t) const;
  /// The specific force for the step from `prev` to an entry holding `next_accel`.
  static Eigen::Vector3d step_accel(const Entry& prev, const Eigen::Vector3d& next_accel);
  /// How the low-passed gyro reading changed across the step from `prev` to `next` (nothing
  /// across a coasted step).
  static ReadingChange step_change(const Entry& prev, const Entry& next);
  /// Feeds an IMU sample placed at t with time offset td (its stamp is t + td) into the low-pass
  /// of the readings (Entry::gyro_smooth).
  Eigen::Vector3d smooth_gyro(double t, double td, const Eigen::Vector3d& gyro);
  /// Marks every entry after index i stale (to be recomputed from entry i and the stored IMU).
  void repropagate_from(std::size_t i) { stale_from_ = std::min(stale_from_, i + 1); }
  /// Recomputes the stale entries up to index k (inclusive).
  void refresh_to(std::size_t k) const;
  void trim();

  StateHistoryConfig config_;
  ImuNoiseConfig noise_;
  // Mutable: reading refreshes stale entries (logically const).
  mutable std::deque<Entry> entries_;
  /// Start of the rest that precedes the oldest entry (static initialisation), NaN when none is
  /// known (a clock step, a received slice) or the oldest entry is no longer the rest's end.
  double rest_since_ = std::numeric_limits<double>::quiet_NaN();
  mutable std::size_t stale_from_ = 1;  ///< index of the first stale entry; entries_.size() when none
  double last_correction_t_ = -1.0;
  /// The low-pass of the gyro readings (Entry::gyro_smooth) after the newest IMU sample, and
  /// that sample's stamp on the IMU's clock (placed time + the offset it was placed with): it
  /// steps by the samples' own spacing, whatever offset each was placed with and however a
  /// correction moved them since (a late scan gives the numbers of an on-time one). Entries
  /// inserted between samples (scan ends) do not advance it.
  Eigen::Vector3d gyro_smooth_ = Eigen::Vector3d::Zero();
  double gyro_smooth_stamp_ = std::numeric_limits<double>::quiet_NaN();
};

/// Interpolates two states on the manifold at fraction a ∈ [0,1] (slerp for rotations).
NavState interpolate(const NavState& x0, const NavState& x1, double a);

}  // namespace fuse

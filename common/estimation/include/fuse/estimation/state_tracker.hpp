// Temporal side of the estimator (DESIGN §1, D_in for IMU and Φ_k): checks each IMU sample,
// runs static initialisation, then propagates into the StateHistory. The single-process
// Estimator and the fuse-state service both own one.
#pragma once

#include <deque>
#include <optional>
#include <utility>
#include <vector>

#include "fuse/core/counters.hpp"
#include "fuse/core/time_gate.hpp"
#include "fuse/core/types.hpp"
#include "fuse/estimation/estimator_config.hpp"
#include "fuse/estimation/state_history.hpp"
#include "fuse/estimation/static_initializer.hpp"
#include "fuse/estimation/tracking_monitor.hpp"

namespace fuse {

/// The rotation rate assumed across a data gap from the (bias-free) rates w0 before (the mean over
/// a window) and w1 after it, per axis: the one of smaller magnitude when both have the same
/// sign, else zero (minmod).
Eigen::Vector3d agreed_rate(const Eigen::Vector3d& w0, const Eigen::Vector3d& w1);

/// Variance (a diagonal covariance) of the motion nobody measured during a data gap of dt
/// seconds: position (½σ_a dt²)², velocity (σ_a dt)², rotation (σ_ω dt)², from
/// divergence.gap_accel_std and gap_gyro_std.
StateVector gap_variance(const DivergenceConfig& divergence, double dt);

/// Widens the prior at t (an entry of `history`) to at least the covariance of a gap of unknown
/// length (estimator.divergence.unknown_gap_s), block by block: a lost track is re-localised from it.
/// Used by StateTracker::widen and by fuse-update on its slice of history.
void widen_prior(StateHistory& history, double t, const EstimatorConfig& config);

class StateTracker {
 public:
  /// Something the tracker did that leaves the prior uncertain (for a TrackingMonitor).
  struct Event {
    TrackingEvent kind;
    double t;
  };

  explicit StateTracker(const EstimatorConfig& config);

  /// D_in: refuses non-finite samples, checks the stamp (TimeGate, estimator.clock: duplicates,
  /// out-of-order samples and isolated jumps are counted and dropped; a forward jump waits for
  /// the following samples; a confirmed clock step re-initialises at the new time), flags gaps,
  /// initialises from a static start, then propagates.
  void ingest(const ImuSample& imu);
  /// Starts the history from a posterior held elsewhere (a restarted fuse-state recovering the
  /// last correction); `held` is the IMU measurement in force at t. Without one (none buffered
  /// from before t) the step from t coasts: the gyro bias as the rate, the specific force that
  /// cancels gravity in the attitude at t (StateHistory::Entry::coasting).
  void restore(double t, const NavState& x, const StateCovariance& P, const std::optional<ImuSample>& held);
  /// Coasts the history from its newest entry to time t as across a data gap (the model of
  /// coast_across_gap: constant velocity, the rotation rate the motion before agrees on, the
  /// covariance grown by gap_variance), for a scan that ends while the IMU is silent: its prior is
  /// then uncertain and it is re-localised. When the IMU returns, propagation continues from the
  /// newest (by then LiDAR-corrected) entry. False when not initialised or t is not after it.
  bool coast_to(double t);
  /// Widens the covariance of the entry at t (which must exist) to at least that of a gap of
  /// unknown length (gap_variance over estimator.divergence.unknown_gap_s), so that the scan there is
  /// re-localised: a lost track keeps trying.
  void widen(double t);
  /// Another clock (a scan's end t) confirms the jump of the IMU samples the time check holds,
  /// when t lies within estimator.clock.max_gap_s of them: the clock step is taken now instead of
  /// after the IMU's own confirmation (up to clock.step_confirm_s of samples for a step back).
  /// False when nothing is held or t does not agree.
  bool confirm_jump(double t);
  /// Data gaps coasted and clock steps taken since the last call.
  std::vector<Event> take_events() { return std::exchange(events_, {}); }

  bool initialised() const { return history_.initialised(); }
  StateHistory& history() { return history_; }
  const StateHistory& history() const { return history_; }
  /// The stamp of the newest IMU sample used, on the state's clock (the history may reach
  /// further: coast_to).
  double last_imu_time() const { return last_imu_t_; }
  /// The LiDAR-IMU time offset in force (the newest state's; estimator.time_offset.initial_s
  /// before initialisation).
  double time_offset() const { return history_.initialised() ? history_.time_offset() : config_.time_offset.initial_s; }
  /// An IMU stamp on the state's clock, the LiDAR's: t_imu − t_d. Samples are placed there.
  double state_time(double t_imu) const { return t_imu - time_offset(); }
  Counters& counters() { return counters_; }
  const Counters& counters() const { return counters_; }

 private:
  /// Uses, re-bases or drops the samples the time check decided (decisions_, gated_).
  void apply_decisions();
  /// A sample that passed the time check.
  void use(const ImuSample& imu);
  /// A confirmed clock step: continue from the newest state at the sample's time.
  void step_clock(const ImuSample& imu, double step);
  void initialise(const NavState& x0, const ImuSample& imu);
  /// Propagates across a data gap up to the sample after it (constant velocity, agreed_rate).
  void coast_across_gap(const ImuSample& imu);
  /// Replaces the newest entry's held measurement by the coasting input (the specific force that
  /// cancels gravity; per axis the rate that the mean rate before and `rate_after` agree on) and
  /// propagates with it to t.
  void coast(const Eigen::Vector3d& rate_after, double t);
  /// Counts a data gap once (imu_gap) and reports it.
  void flag_gap(double t, const std::string& message);
  /// The step kept with the newest entry, where a gap coasted from `reached` ends: the unmodelled
  /// motion since `reached` (EntryStep's coast; a gap coasted scan by scan grows per scan: each
  /// scan in it measured the pose at its end) and the levelling with `accel` when a sample ends
  /// the gap.
  EntryStep gap_step(double reached, const Eigen::Vector3d* accel) const;

  EstimatorConfig config_;
  StaticInitializer initializer_;
  StateHistory history_;
  TimeGate gate_;
  std::deque<ImuSample> gated_;                ///< samples pushed into the gate, not yet decided
  std::vector<TimeGate::Decision> decisions_;
  double last_imu_t_ = -1.0;
  bool coasted_ = false;  ///< coast_to extended the history past the newest IMU sample
  std::vector<Event> events_;
  Counters counters_;
};

}  // namespace fuse

#include "fuse/estimation/state_tracker.hpp"

#include <cmath>

#include "fuse/core/logging.hpp"

namespace fuse {

namespace {
/// Two times closer than this are the same instant (as in StateHistory).
constexpr double kSameTime = 1e-6;
}  // namespace

StateTracker::StateTracker(const EstimatorConfig& config)
    : config_(config),
      initializer_(config.init),
      history_(config.history, config.imu),
      gate_(config.clock),
      counters_(logger("estimator")) {}

void StateTracker::ingest(const ImuSample& imu) {
  if (!imu.gyro.allFinite() || !imu.accel.allFinite() || !std::isfinite(imu.t)) {
    counters_.count("imu_not_finite", "IMU sample with a non-finite value refused");
    return;
  }
  // The time check may hold a sample (a jump waiting for confirmation) and decide it later.
  gated_.push_back(imu);
  gate_.push(imu.t, decisions_);
  apply_decisions();
}

bool StateTracker::confirm_jump(double t) {
  const std::optional<double> held = gate_.newest_held();
  if (!held || std::abs(t - *held) > config_.clock.max_gap_s) return false;
  gate_.confirm(decisions_);
  apply_decisions();
  return true;
}

void StateTracker::apply_decisions() {
  // Decisions come in push order, one per sample pushed: each takes its sample from the front.
  for (const TimeGate::Decision& d : decisions_) {
    // The time check judges the IMU's own clock; the sample is used on the state's.
    ImuSample sample = gated_.front();
    gated_.pop_front();
    sample.t = state_time(sample.t);
    switch (d.verdict) {
      case TimeGate::Verdict::kAccept:
        use(sample);
        break;
      case TimeGate::Verdict::kClockStep:
        step_clock(sample, d.step);
        break;
      case TimeGate::Verdict::kDuplicate:
        counters_.count("imu_duplicate", fmt::format("IMU sample at t={:.6f} repeats the previous stamp: dropped", d.t));
        break;
      case TimeGate::Verdict::kOutOfOrder:
        counters_.count("imu_out_of_order",
                        fmt::format("IMU sample at t={:.6f} is {:.6f} s behind the stream: dropped", d.t, -d.step));
        break;
      case TimeGate::Verdict::kOutlier:
        counters_.count("imu_time_outlier",
                        fmt::format("IMU sample at t={:.6f} jumps {:+.3f} s away from the stream and not the samples "
                                    "after it (beyond estimator.clock.hold_gap_s, not confirmed): dropped",
                                    d.t, d.step));
        break;
    }
  }
}

void StateTracker::use(const ImuSample& imu) {
  const double gap = last_imu_t_ >= 0.0 ? imu.t - last_imu_t_ : 0.0;
  if (gap > config_.divergence.max_imu_gap && !coasted_) {
    flag_gap(imu.t, "IMU data gap of " + std::to_string(gap) + " s before t=" + std::to_string(imu.t));
  }
  last_imu_t_ = imu.t;
  if (!history_.initialised()) {
    const std::size_t restarts = initializer_.restarts();
    if (auto x0 = initializer_.add(imu, config_.gravity_magnitude)) initialise(*x0, imu);
    if (initializer_.restarts() > restarts) {
      counters_.count("init_not_at_rest",
                      fmt::format("not initialised: the IMU window ending at t={:.3f} shows motion; static "
                                  "initialisation waits for the sensor to rest {:.2f} s (estimator.init.duration_s)",
                                  imu.t, config_.init.duration_s));
    }
    return;
  }
  const double step = imu.t - history_.newest().t;
  if (step < -kSameTime) {
    // The history already reaches past this sample: coasted (coast_to) or extrapolated to a scan
    // that arrived before it, and corrected there. Propagating from the newest entry with it
    // would run backwards.
    counters_.count("imu_older_than_state",
                    fmt::format("IMU sample at t={:.6f} arrived after the state was {} to a scan ending at t={:.6f}: "
                                "dropped",
                                imu.t, coasted_ ? "coasted" : "extrapolated", history_.newest().t));
    return;
  }
  // After a coast to a scan inside the gap (coast_to), this sample closes the gap however short its
  // last stretch: taken as a plain IMU step, that stretch would add no unmodelled motion.
  const bool closes_coast = coasted_;
  coasted_ = false;
  if (step > config_.divergence.max_imu_gap || closes_coast) {
    coast_across_gap(imu);
    return;
  }
  history_.add_imu(imu);
}

void StateTracker::flag_gap(double t, const std::string& message) {
  counters_.count("imu_gap", message);
  if (history_.initialised()) events_.push_back({TrackingEvent::kDataGap, t});
}

void StateTracker::step_clock(const ImuSample& imu, double step) {
  // The clock stepped (confirmed by the samples after the jump, or by a stream that stayed behind):
  // continue from the newest state at the new time, with the uncertainty of a gap of unknown
  // length, so that the LiDAR re-localises it against the map. The map has no time, so nothing
  // else needs to agree on an offset (docs/architecture.md, "Time is checked like any input").
  counters_.count("imu_clock_step",
                  fmt::format("IMU clock step of {:+.3f} s to t={:.6f} (beyond estimator.clock.max_gap_s = {} s, "
                              "confirmed by the samples after it or by the scans' clock): the state continues at the new time as after a "
                              "gap of unknown length (divergence.unknown_gap_s) and is re-localised against the map",
                              step, imu.t, config_.clock.max_gap_s));
  last_imu_t_ = imu.t;
  coasted_ = false;
  if (!history_.initialised()) {
    initializer_ = StaticInitializer(config_.init);  // a window across the step is no rest
    if (auto x0 = initializer_.add(imu, config_.gravity_magnitude)) initialise(*x0, imu);
    return;
  }
  NavState x = history_.newest().x;
  StateCovariance P = history_.newest().P;
  P.diagonal() += gap_variance(config_.divergence, config_.divergence.unknown_gap_s);
  if (config_.divergence.gap_level) {
    // As after a data gap: the tilt σ of an unknown gap (σ_ω G ≈ 1 rad) would leave the LiDAR to
    // find roll and pitch too (measured without it: ATE 198 instead of 9 mm after a +100 s step).
    level_with_accelerometer(imu.accel - x.ba, config_.divergence.gap_accel_std / x.g.norm(), x, P);
  }
  history_.reset(imu.t, x, P, imu);
  events_.push_back({TrackingEvent::kClockStep, imu.t});
}

void StateTracker::initialise(const NavState& x0_in, const ImuSample& imu) {
  NavState x0 = x0_in;
  x0.R_IL = config_.T_imu_lidar.linear();
  x0.p_IL = config_.T_imu_lidar.translation();
  const auto& c = config_.initial_covariance;
  StateCovariance P = StateCovariance::Zero();
  auto set = [&P](int idx, int n, double std) { P.block(idx, idx, n, n) = Eigen::MatrixXd::Identity(n, n) * std * std; };
  set(Idx::kPos, 3, c.position_std);
  P.block<3, 3>(Idx::kRot, Idx::kRot) = Eigen::Vector3d(c.roll_pitch_std * c.roll_pitch_std, c.roll_pitch_std * c.roll_pitch_std,
                                                        c.yaw_std * c.yaw_std).asDiagonal();
  set(Idx::kVel, 3, c.velocity_std);
  set(Idx::kBg, 3, c.gyro_bias_std);
  set(Idx::kBa, 3, c.accel_bias_std);
  if (config_.estimate_extrinsic) {
    set(Idx::kExtRot, 3, c.extrinsic_rotation_std);
    set(Idx::kExtPos, 3, c.extrinsic_translation_std);
  }
  if (config_.estimate_gravity) set(Idx::kGrav, 2, c.gravity_std);
  x0.td = config_.time_offset.initial_s;
  if (config_.time_offset.estimate) set(Idx::kTimeOffset, 1, config_.time_offset.std_s);
  history_.reset(imu.t, x0, P, imu, initializer_.rest_since());
  logger("estimator")->info("initialised at t={:.3f}: gyro bias [{:.5f} {:.5f} {:.5f}] rad/s after {} restarts", imu.t,
                            x0.bg.x(), x0.bg.y(), x0.bg.z(), initializer_.restarts());
}

void StateTracker::coast(const Eigen::Vector3d& rate_after, double t) {
  // Nothing measured the motion: coast at constant velocity (the specific force that cancels
  // gravity, f = R⊤(−g) + b_a) and, per axis, at the rotation rate that the motion before the gap
  // (its mean rate over divergence.gap_rate_window) and rate_after agree on.
  const StateHistory::Entry& before = history_.newest();
  Eigen::Vector3d mean_rate = Eigen::Vector3d::Zero();
  const auto window = history_.entries_between(before.t - config_.divergence.gap_rate_window, before.t);
  for (const StateHistory::Entry* e : window) mean_rate += e->gyro - e->x.bg;
  if (!window.empty()) mean_rate /= static_cast<double>(window.size());
  ImuSample input;
  input.t = before.t;
  input.gyro = agreed_rate(mean_rate, rate_after) + before.x.bg;
  input.accel = before.x.R.transpose() * (-before.x.g) + before.x.ba;
  history_.add_imu(input);  // same instant: replaces the held measurement
  history_.mark_newest_coasting();
  input.t = t;
  history_.add_imu(input);
  history_.mark_newest_coasting();  // until a real sample: the step to it coasts too
}

void StateTracker::coast_across_gap(const ImuSample& imu) {
  // Coast up to the sample after the gap, take the sample as usual, and grow the covariance by
  // the unmodelled motion; the sample's accelerometer levels the coasted attitude.
  constexpr double kLastStep = 0.001;  // s: the real sample closes the gap over the last millisecond
  const double reached = history_.newest().t;
  coast(imu.gyro - history_.newest().x.bg, std::max(imu.t - kLastStep, reached));
  history_.add_step_to_newest(gap_step(reached, &imu.accel));
  history_.add_imu(imu);
}

bool StateTracker::coast_to(double t) {
  if (!history_.initialised() || !(t > history_.newest().t)) return false;
  const StateHistory::Entry& before = history_.newest();
  if (!coasted_) {
    flag_gap(t, fmt::format("IMU silent since t={:.6f} while scans arrive: coasting to the scan end t={:.6f}",
                            last_imu_t_, t));
  }
  const double reached = before.t;
  // No sample after the gap yet: the rate the motion before agrees on with the newest held rate.
  coast(before.gyro - before.x.bg, t);
  history_.add_step_to_newest(gap_step(reached, nullptr));
  coasted_ = true;
  return true;
}

EntryStep StateTracker::gap_step(double reached, const Eigen::Vector3d* accel) const {
  EntryStep step;
  // gap_variance(t − reached), accrued along the coast (a held scan inside it takes its part).
  step.coast_from = reached;
  step.coast_accel_std = config_.divergence.gap_accel_std;
  step.coast_gyro_std = config_.divergence.gap_gyro_std;
  if (accel && config_.divergence.gap_level) {
    step.level_accel = *accel;
    step.level_sigma = config_.divergence.gap_accel_std / history_.newest().x.g.norm();
  }
  return step;
}

void StateTracker::widen(double t) { widen_prior(history_, t, config_); }

void widen_prior(StateHistory& history, double t, const EstimatorConfig& config) {
  // At least the covariance of a gap of unknown length, block by block (position, velocity,
  // rotation): widening an already uncertain prior again would only lose information.
  const StateQuery q = history.query(t);
  if (!q.ok()) return;
  const StateVector unknown = gap_variance(config.divergence, config.divergence.unknown_gap_s);
  StateVector add = StateVector::Zero();
  for (int idx : {Idx::kPos, Idx::kVel, Idx::kRot}) {
    if (q.P.block<3, 3>(idx, idx).diagonal().maxCoeff() < unknown(idx)) add.segment<3>(idx) = unknown.segment<3>(idx);
  }
  history.inflate(t, add);
}

Eigen::Vector3d agreed_rate(const Eigen::Vector3d& w0, const Eigen::Vector3d& w1) {
  // minmod: a steady turn (both alike) keeps its rate; rates of opposite sign give none, and a
  // turn that starts or ends in the gap gives the smaller. With w0 the mean over the motion before
  // the gap, an oscillation (handheld sway, a legged gait) averages out instead of one end's peak
  // rate being integrated over the whole gap (a 0.3 rad/s sway peak over 1 s is 17°).
  Eigen::Vector3d w;
  for (int i = 0; i < 3; ++i) {
    w(i) = w0(i) * w1(i) <= 0.0 ? 0.0 : (std::abs(w0(i)) < std::abs(w1(i)) ? w0(i) : w1(i));
  }
  return w;
}

StateVector gap_variance(const DivergenceConfig& divergence, double dt) {
  return unmodelled_motion_variance(divergence.gap_accel_std, divergence.gap_gyro_std, dt);
}

void StateTracker::restore(double t, const NavState& x, const StateCovariance& P, const std::optional<ImuSample>& held) {
  if (held) {
    history_.reset(t, x, P, *held);
  } else {
    history_.reset(t, x, P, rest_measurement(x, t));  // coasted across any gap after
    history_.mark_newest_coasting();
  }
  last_imu_t_ = std::max(last_imu_t_, t);
  gate_.reset(last_imu_t_ + x.td);  // the time check runs on the IMU's clock
  gated_.clear();
  coasted_ = false;
  events_.push_back({TrackingEvent::kRestart, t});
}

}  // namespace fuse

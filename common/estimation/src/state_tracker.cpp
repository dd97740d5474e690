#include "fuse/estimation/state_tracker.hpp"

#include <cmath>

#include "fuse/core/logging.hpp"

namespace fuse {

StateTracker::StateTracker(const EstimatorConfig& config)
    : config_(config), initializer_(config.init), history_(config.history, config.imu), counters_(logger("estimator")) {}

void StateTracker::ingest(const ImuSample& imu) {
  if (!imu.gyro.allFinite() || !imu.accel.allFinite() || !std::isfinite(imu.t)) {
    counters_.count("imu_not_finite", "IMU sample with a non-finite value refused");
    return;
  }
  if (last_imu_t_ >= 0.0 && imu.t <= last_imu_t_) {
    counters_.count("imu_time_not_increasing", "IMU sample at t=" + std::to_string(imu.t) + " not after the previous one, refused");
    return;
  }
  const double gap = last_imu_t_ >= 0.0 ? imu.t - last_imu_t_ : 0.0;
  const bool flagged = gap > config_.divergence.max_imu_gap;
  if (flagged) {
    counters_.count("imu_gap", "IMU data gap of " + std::to_string(gap) + " s before t=" + std::to_string(imu.t));
  }
  last_imu_t_ = imu.t;
  if (flagged && history_.initialised()) {
    coast_across_gap(imu);
    return;
  }
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
  history_.add_imu(imu);
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
  history_.reset(imu.t, x0, P, imu);
  logger("estimator")->info("initialised at t={:.3f}: gyro bias [{:.5f} {:.5f} {:.5f}] rad/s after {} restarts", imu.t,
                            x0.bg.x(), x0.bg.y(), x0.bg.z(), initializer_.restarts());
}

void StateTracker::coast_across_gap(const ImuSample& imu) {
  // Nothing measured the motion during the gap: coast at constant velocity (the specific force
  // that cancels gravity, f = R⊤(−g) + b_a) and, per axis, at the rotation rate that the motion
  // before the gap (its mean rate over divergence.gap_rate_window) and the sample after it agree
  // on; then take the new sample as usual, and grow the covariance by the unmodelled motion.
  constexpr double kLastStep = 0.001;  // s: the real sample closes the gap over the last millisecond
  const StateHistory::Entry& before = history_.newest();
  const double gap = imu.t - before.t;
  Eigen::Vector3d mean_rate = Eigen::Vector3d::Zero();
  const auto window = history_.entries_between(before.t - config_.divergence.gap_rate_window, before.t);
  for (const StateHistory::Entry* e : window) mean_rate += e->gyro - e->x.bg;
  if (!window.empty()) mean_rate /= static_cast<double>(window.size());
  ImuSample coast;
  coast.t = before.t;
  coast.gyro = agreed_rate(mean_rate, imu.gyro - before.x.bg) + before.x.bg;
  coast.accel = before.x.R.transpose() * (-before.x.g) + before.x.ba;
  history_.add_imu(coast);  // same instant: replaces the held measurement
  coast.t = imu.t - kLastStep;
  history_.add_imu(coast);
  NavState x = history_.newest().x;
  StateCovariance P = history_.newest().P + gap_noise(gap);
  if (config_.divergence.gap_level) {
    level_with_accelerometer(imu.accel - x.ba, config_.divergence.gap_accel_std / x.g.norm(), x, P);
  }
  history_.amend_newest(x, P);
  history_.add_imu(imu);
}

void level_with_accelerometer(const Eigen::Vector3d& f, double sigma, NavState& x, StateCovariance& P) {
  // Iterated EKF on the rotation block (right perturbation R = R̂·Exp(δθ)):
  //   h(x) = R_WIᵀu,  H = ∂h/∂δθ = [R_WIᵀu]×,  r = f/|f| − h(x_i),
  //   δx_{i+1} = K_i (r_i + H_i δx_i),  K_i = P Hᵢᵀ (H_i P_rr Hᵢᵀ + σ² I)⁻¹,
  // relinearised at x_i = x̂ ⊞ δx_i (a gap can leave tens of degrees to correct), P ← (I − K H) P.
  constexpr int kIterations = 5;
  if (!(f.norm() > 0.0) || !(sigma > 0.0)) return;
  const Eigen::Vector3d z = f.normalized();
  const Eigen::Vector3d u = -x.g.normalized();
  const NavState x0 = x;
  StateVector dx = StateVector::Zero();
  Eigen::Matrix<double, kStateDim, 3> K;
  Eigen::Matrix3d H;
  for (int i = 0; i < kIterations; ++i) {
    const Eigen::Vector3d h = x.R.transpose() * u;
    H = so3::hat(h);
    const Eigen::Matrix3d S = H * P.block<3, 3>(Idx::kRot, Idx::kRot) * H.transpose() +
                              sigma * sigma * Eigen::Matrix3d::Identity();
    K = P.middleCols<3>(Idx::kRot) * H.transpose() * S.inverse();
    dx = K * (z - h + H * dx.segment<3>(Idx::kRot));
    x = x0.boxplus(dx);
  }
  const StateCovariance KHP = K * H * P.middleRows<3>(Idx::kRot);
  P -= KHP;
  P = 0.5 * (P + P.transpose()).eval();
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

StateCovariance StateTracker::gap_noise(double dt) const {
  const double sa = config_.divergence.gap_accel_std, sw = config_.divergence.gap_gyro_std;
  StateCovariance Q = StateCovariance::Zero();
  Q.block<3, 3>(Idx::kPos, Idx::kPos).diagonal().setConstant(std::pow(0.5 * sa * dt * dt, 2));
  Q.block<3, 3>(Idx::kVel, Idx::kVel).diagonal().setConstant(std::pow(sa * dt, 2));
  Q.block<3, 3>(Idx::kRot, Idx::kRot).diagonal().setConstant(std::pow(sw * dt, 2));
  return Q;
}

void StateTracker::restore(double t, const NavState& x, const StateCovariance& P, const ImuSample& held) {
  history_.reset(t, x, P, held);
  last_imu_t_ = std::max(last_imu_t_, t);
}

}  // namespace fuse

#include "fuse/estimation/zero_velocity.hpp"

#include <algorithm>
#include <cmath>

namespace fuse {

namespace {
bool in(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }
}  // namespace

void ZeroVelocityConfig::load(ConfigNode& node) {
  node.get("enabled", enabled).get("max_speed", max_speed).get("max_rate", max_rate).get("max_accel", max_accel);
  node.get("max_gyro_std", max_gyro_std).get("max_accel_std", max_accel_std).get("velocity_std", velocity_std);
  node.check(in(max_speed, 0.0, 5.0), "max_speed", "must be in [0, 5] m/s");
  node.check(in(max_rate, 0.0, 1.0), "max_rate", "must be in [0, 1] rad/s");
  node.check(in(max_accel, 0.0, 5.0), "max_accel", "must be in [0, 5] m/s^2");
  node.check(in(max_gyro_std, 0.0, 1.0), "max_gyro_std", "must be in [0, 1] rad/s");
  node.check(in(max_accel_std, 0.0, 5.0), "max_accel_std", "must be in [0, 5] m/s^2");
  node.check(in(velocity_std, 1e-4, 1.0), "velocity_std", "must be in [1e-4, 1] m/s");
  node.finish();
}

ImuWindow imu_window(const StateHistory& history, double t0, double t1, double max_step) {
  ImuWindow w;
  if (!history.initialised() || !(t1 > t0)) return w;
  // Entry i holds its sample over [t_i, t_{i+1}); the part of that inside [t0, t1] weighs it.
  const auto entries = history.entries_covering(t0, t1);
  Eigen::Vector3d s_g = Eigen::Vector3d::Zero(), s_a = Eigen::Vector3d::Zero();
  Eigen::Vector3d q_g = Eigen::Vector3d::Zero(), q_a = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const double a = std::max(entries[i]->t, t0);
    const double b = std::min(i + 1 < entries.size() ? entries[i + 1]->t : t1, t1);
    if (!(b > a)) continue;
    const double dt = b - a;
    const StateHistory::Entry& e = *entries[i];
    const double held = (i + 1 < entries.size() ? entries[i + 1]->t : t1) - e.t;
    if (e.coasting || held > max_step) return ImuWindow{};  // not measured throughout
    s_g += dt * e.gyro;
    s_a += dt * e.accel;
    q_g += dt * e.gyro.cwiseAbs2();
    q_a += dt * e.accel.cwiseAbs2();
    w.duration += dt;
  }
  if (!(w.duration > 0.0)) return w;
  w.measured = true;
  w.mean_gyro = s_g / w.duration;
  w.mean_accel = s_a / w.duration;
  // Var = E[x²] − E[x]², per axis; the larger axis' RMS spread.
  const Eigen::Vector3d var_g = (q_g / w.duration - w.mean_gyro.cwiseAbs2()).cwiseMax(0.0);
  const Eigen::Vector3d var_a = (q_a / w.duration - w.mean_accel.cwiseAbs2()).cwiseMax(0.0);
  w.gyro_std = std::sqrt(var_g.maxCoeff());
  w.accel_std = std::sqrt(var_a.maxCoeff());
  return w;
}

RestCheck check_rest(const ImuWindow& w, const NavState& x, const ZeroVelocityConfig& config) {
  RestCheck c;
  if (!w.measured) return c;
  const ImuSample rest = rest_measurement(x, 0.0);
  c.speed = x.v.norm();
  c.rate = (w.mean_gyro - rest.gyro).norm();
  c.accel = (w.mean_accel - rest.accel).norm();
  c.gyro_std = w.gyro_std;
  c.accel_std = w.accel_std;
  c.at_rest = c.speed <= config.max_speed && c.rate <= config.max_rate && c.accel <= config.max_accel &&
              c.gyro_std <= config.max_gyro_std && c.accel_std <= config.max_accel_std;
  return c;
}

void zero_velocity_update(double velocity_std, NavState& x, StateCovariance& P) {
  // Linear in δv: H selects the velocity block, so H P Hᵀ = P_vv and P Hᵀ = P's velocity columns.
  const Eigen::Matrix3d S = P.block<3, 3>(Idx::kVel, Idx::kVel) + velocity_std * velocity_std * Eigen::Matrix3d::Identity();
  const Eigen::Matrix<double, kStateDim, 3> K = P.middleCols<3>(Idx::kVel) * S.inverse();
  const StateVector dx = K * (-x.v);
  x = x.boxplus(dx);
  const StateCovariance KHP = K * P.middleRows<3>(Idx::kVel);
  P -= KHP;
  P = 0.5 * (P + P.transpose()).eval();
}

}  // namespace fuse

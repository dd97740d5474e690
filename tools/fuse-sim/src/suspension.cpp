#include "fuse/sim/suspension.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace fuse::sim {

namespace {
constexpr double kTwoPi = 6.283185307179586476925286766559;
// Integration grid: ~350 RK4 steps per natural period at 1.4 Hz, so the stored nodes are exact to
// round-off and the quintic interpolation between them is smooth far below the IMU period.
constexpr double kStepS = 0.002;
// Share of the final rest over which the last of the settling oscillation is faded out.
constexpr double kSettleShare = 0.5;

using State = Eigen::Vector4d;  // pitch, pitch rate, roll, roll rate

// Pitch (nose down when braking) and roll (out of the turn) that the acceleration would hold.
Eigen::Vector2d targets(const SuspensionConfig& c, const Eigen::Vector2d& accel) {
  return {-c.pitch_per_accel * accel.x(), c.roll_per_accel * accel.y()};
}

// The damped spring: x'' = w^2 (target - x) - 2 zeta w x'.
State derivative(const State& y, const Eigen::Vector2d& target, double w, double zeta) {
  return {y[1], w * w * (target.x() - y[0]) - 2.0 * zeta * w * y[1], y[3],
          w * w * (target.y() - y[2]) - 2.0 * zeta * w * y[3]};
}

// A quintic on s in [0, 1] from value, first and second derivative at both ends (p at 0, q at 1,
// derivatives with respect to s); returns the value and the first two s-derivatives at s.
Eigen::Vector3d quintic(double p0, double p1, double p2, double q0, double q1, double q2, double s) {
  const double d = q0 - p0;
  const double c[6] = {p0,
                       p1,
                       0.5 * p2,
                       10.0 * d - 6.0 * p1 - 4.0 * q1 - 1.5 * p2 + 0.5 * q2,
                       -15.0 * d + 8.0 * p1 + 7.0 * q1 + 1.5 * p2 - q2,
                       6.0 * d - 3.0 * p1 - 3.0 * q1 - 0.5 * p2 + 0.5 * q2};
  double v = c[5], v1 = 0.0, v2 = 0.0;
  for (int i = 4; i >= 0; --i) {  // Horner with derivatives
    v2 = v2 * s + 2.0 * v1;
    v1 = v1 * s + v;
    v = v * s + c[i];
  }
  return {v, v1, v2};
}
}  // namespace

SuspensionResponse::SuspensionResponse(const SuspensionConfig& config, double duration, double settle_from,
                                       const Acceleration& accel)
    : config_(config), duration_(duration), settle_from_(settle_from) {
  if (!(config.natural_hz > 0.0) || !(config.damping_ratio > 0.0) || !(duration > 0.0) ||
      !std::isfinite(config.natural_hz) || !std::isfinite(config.damping_ratio) || !std::isfinite(duration) ||
      !std::isfinite(config.pitch_per_accel) || !std::isfinite(config.roll_per_accel))
    throw std::invalid_argument("suspension: natural frequency, damping and duration must be positive and finite");
  const double w = kTwoPi * config.natural_hz, zeta = config.damping_ratio;
  const std::size_t n = static_cast<std::size_t>(std::ceil(duration / kStepS));
  step_ = duration / static_cast<double>(n);  // the last node falls exactly on the end
  nodes_.resize(n + 1);
  const auto node = [&](const State& y, const Eigen::Vector2d& target) {
    const State d = derivative(y, target, w, zeta);
    Eigen::Matrix<double, 6, 1> out;
    out << y[0], y[1], d[1], y[2], y[3], d[3];
    return out;
  };
  State y = State::Zero();  // at rest: no acceleration, no deflection
  Eigen::Vector2d target = targets(config, accel(0.0));
  nodes_[0] = node(y, target);
  const double h = step_;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) * h;
    const Eigen::Vector2d mid = targets(config, accel(t + 0.5 * h));
    const Eigen::Vector2d end = targets(config, accel(static_cast<double>(i + 1) * h));
    const State k1 = derivative(y, target, w, zeta);
    const State k2 = derivative(y + 0.5 * h * k1, mid, w, zeta);
    const State k3 = derivative(y + 0.5 * h * k2, mid, w, zeta);
    const State k4 = derivative(y + h * k3, end, w, zeta);
    y += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    target = end;
    nodes_[i + 1] = node(y, target);
  }
}

void SuspensionResponse::at(double t, Jet& pitch, Jet& roll) const {
  const double tc = std::clamp(t, 0.0, duration_), h = step_;
  const std::size_t i = std::min(static_cast<std::size_t>(tc / h), nodes_.size() - 2);
  const double s = std::clamp(tc / h - static_cast<double>(i), 0.0, 1.0);
  const auto& a = nodes_[i];
  const auto& b = nodes_[i + 1];
  const auto channel = [&](int k) {
    const Eigen::Vector3d q = quintic(a[k], h * a[k + 1], h * h * a[k + 2], b[k], h * b[k + 1], h * h * b[k + 2], s);
    return Jet{q[0], q[1] / h, q[2] / (h * h)};
  };
  pitch = channel(0);
  roll = channel(3);
  // Settling: faded out over the first half of the final rest, exactly zero after it.
  const double settled = settle_from_ + kSettleShare * (duration_ - settle_from_);
  if (tc >= settled && settled > settle_from_) {
    pitch = roll = Jet{};
  } else if (tc > settle_from_) {
    // Fade w = 1 - S(x), S(x) = 10x^3 - 15x^4 + 6x^5 (S', S'' vanish at both ends): w, w', w''.
    const double T = settled - settle_from_, x = (tc - settle_from_) / T;
    const Jet fade{1.0 - x * x * x * (10.0 - 15.0 * x + 6.0 * x * x), -30.0 * x * x * (1.0 - x) * (1.0 - x) / T,
                   -60.0 * x * (1.0 - x) * (1.0 - 2.0 * x) / (T * T)};
    pitch = fade * pitch;
    roll = fade * roll;
  }
}

}  // namespace fuse::sim

// Vehicle suspension: a car body pitches and rolls on its springs in response to the longitudinal
// and lateral acceleration: the nose dips when braking and rises when accelerating, the body
// rolls out of a turn. Each angle follows a damped spring driven by the acceleration,
//   x'' + 2 zeta w x' + w^2 x = w^2 k a(t)      (w = 2 pi natural_hz, x = 0 at rest),
// integrated once from rest (RK4 on a fine grid) and then evaluated by quintic Hermite
// interpolation of (x, x', x'') between grid nodes. The angle, its rate and its acceleration are
// therefore exact derivatives of one C2 function of time, so an ideal IMU stays consistent with
// the pose. Once the vehicle has stopped, the last of the settling oscillation is faded out by a
// smoothstep, so the body is exactly at rest at the end (like the rest of the trajectory).
#pragma once

#include <Eigen/Core>
#include <functional>
#include <vector>

#include "fuse/sim/jet.hpp"

namespace fuse::sim {

struct SuspensionConfig {
  bool enabled = false;
  double pitch_per_accel = 0.0;  ///< rad of nose-down pitch per m/s^2 of deceleration (> 0)
  double roll_per_accel = 0.0;   ///< rad of roll out of the turn per m/s^2 of lateral acceleration (> 0)
  double natural_hz = 1.4;       ///< body pitch / roll natural frequency
  double damping_ratio = 0.45;   ///< zeta (< 1: a slight overshoot, as on a passenger car)
};

class SuspensionResponse {
 public:
  /// Longitudinal (forward) and lateral (leftward) acceleration of the body in m/s^2 at time t
  /// (seconds since the start of the motion).
  using Acceleration = std::function<Eigen::Vector2d(double)>;

  /// Integrates the response from rest at t = 0 to `duration`, faded to zero over the first half
  /// of [settle_from, duration] (the vehicle at rest from settle_from on; >= duration: no fade). Throws
  /// std::invalid_argument on a non-positive frequency, damping or duration.
  SuspensionResponse(const SuspensionConfig& config, double duration, double settle_from, const Acceleration& accel);

  /// Pitch (positive: nose down) and roll (positive: left side up, R = Rz Ry Rx) with their first
  /// two time derivatives at t (seconds since the start; clamped to [0, duration]).
  void at(double t, Jet& pitch, Jet& roll) const;
  const SuspensionConfig& config() const { return config_; }

 private:
  SuspensionConfig config_;
  double step_ = 0.0, duration_ = 0.0, settle_from_ = 0.0;
  /// Per grid node: pitch x, x', x'' then roll x, x', x''.
  std::vector<Eigen::Matrix<double, 6, 1>> nodes_;
};

}  // namespace fuse::sim

// Zero-velocity update (estimator.zero_velocity): a vehicle parked, or stopped at a light, is at
// rest, and saying so pins what the LiDAR alone pins weakly. Parked on a street, the scans of a
// young map seen from one place hardly constrain the position along it, and the accelerometer
// bias (σ 0.1 m/s² at the start) walks the position along the street by ½·σ_a·t²: 5 cm in a
// second. Through the velocity's correlations a zero-velocity update also settles the
// accelerometer bias against the attitude, as a rest does at initialisation.
//
// A scan's IMU samples (its window [t_start, t_end] in the history, duration-weighted, measured
// throughout: no data gap) call the sensor at rest when all of these hold, with the prior x at t_end:
//   |x.v| ≤ max_speed                          a moving vehicle on a smooth road reads as still
//   |mean(ω̃) − b_g| ≤ max_rate                  not turning
//   |mean(f̃) − (R_WIᵀ(−g) + b_a)| ≤ max_accel   not accelerating (the rest measurement, state_history.hpp)
//   RMS(ω̃ − mean) ≤ max_gyro_std, RMS(f̃ − mean) ≤ max_accel_std   no sway (a handheld sensor)
// and the update is then a Kalman update with z = 0, h(x) = v, H = [0 … I₃ … 0] at δv, R = σ_v² I₃:
//   K = P Hᵀ (H P Hᵀ + R)⁻¹,  δx = K (0 − v),  x ← x ⊞ δx,  P ← (I − K H) P.
#pragma once

#include <Eigen/Core>

#include "fuse/core/config.hpp"
#include "fuse/estimation/state.hpp"
#include "fuse/estimation/state_history.hpp"

namespace fuse {

struct ZeroVelocityConfig {
  bool enabled = true;
  double max_speed = 0.3;      ///< m/s: the prior's speed at most
  double max_rate = 0.02;      ///< rad/s: bias-free mean rotation rate over the scan at most
  double max_accel = 0.1;      ///< m/s²: mean specific force's distance from the rest measurement at most
  double max_gyro_std = 0.02;  ///< rad/s: RMS spread of the rate over the scan at most
  double max_accel_std = 0.2;  ///< m/s²: RMS spread of the specific force over the scan at most
  double velocity_std = 0.005;  ///< m/s: σ_v of the update (a parked car: the truth is 0)
  void load(ConfigNode& node);
};

/// The IMU over [t0, t1] of a history: duration-weighted mean and RMS spread (the larger axis'
/// of the three) of the held gyro and accelerometer samples. Only a window the IMU measured
/// throughout counts: a coasted stretch (a data gap, an IMU silent at the scan end) holds the
/// sample from before it, which says nothing of the motion during it (a walker who set off
/// while the IMU was silent would read as still).
struct ImuWindow {
  bool measured = false;  ///< every sample holds for at most max_step and none is coasted
  double duration = 0.0;  ///< s covered
  Eigen::Vector3d mean_gyro = Eigen::Vector3d::Zero(), mean_accel = Eigen::Vector3d::Zero();
  double gyro_std = 0.0, accel_std = 0.0;
};
ImuWindow imu_window(const StateHistory& history, double t0, double t1, double max_step);

/// What the rest test found for a scan (the test in the header: every figure against its bound).
struct RestCheck {
  bool at_rest = false;
  double speed = 0.0, rate = 0.0, accel = 0.0, gyro_std = 0.0, accel_std = 0.0;
};
RestCheck check_rest(const ImuWindow& w, const NavState& x, const ZeroVelocityConfig& config);

/// The Kalman update of (x, P) with the measurement v = 0, noise σ_v² I₃ (header).
void zero_velocity_update(double velocity_std, NavState& x, StateCovariance& P);

}  // namespace fuse

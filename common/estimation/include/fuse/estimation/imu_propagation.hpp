// IMU propagation of the nominal state and the error-state covariance (DESIGN §1, Φ_k):
//   R' = R·Exp((ω_m − b_g)·dt),  a_W = R·(a_m − b_a) + g,
//   p' = p + v·dt + ½·a_W·dt²,   v' = v + a_W·dt,
//   P' = F·P·Fᵀ + G·Q·Gᵀ   (right-perturbation error-state Jacobians, see propagate()).
#pragma once

#include <Eigen/Core>

#include "fuse/core/config.hpp"
#include "fuse/estimation/state.hpp"

namespace fuse {

/// Continuous-time IMU noise densities (datasheet units).
struct ImuNoiseConfig {
  double gyro_noise_density = 1.0e-4;   ///< rad/s/√Hz
  double accel_noise_density = 1.5e-3;  ///< m/s²/√Hz
  double gyro_bias_random_walk = 3.0e-5;   ///< rad/s²/√Hz
  double accel_bias_random_walk = 5.0e-4;  ///< m/s³/√Hz
  /// Multiplies every density: covers unmodelled effects (vibration, integration error).
  double inflation = 1.0;
  /// Ablation switch. false: no F·P·Fᵀ + G·Q·Gᵀ; the prior of every update is instead the fixed
  /// covariance below (pose, velocity and bias blocks; others keep their values).
  bool propagate_covariance = true;
  /// s/√s: random walk of the LiDAR-IMU time offset (not a key of this section: set from
  /// estimator.time_offset, 0 while the offset is not estimated, which keeps it fixed).
  double time_offset_random_walk = 0.0;
  /// s: time constant of the low-pass of the gyro readings whose change ties the time offset to
  /// the attitude (0: the raw readings). Not a key of this section: set from
  /// estimator.time_offset.rate_smoothing_s (StateHistory::Entry::gyro_smooth).
  double time_offset_rate_smoothing_s = 0.0;
  double fixed_position_std = 0.02;     ///< m
  double fixed_rotation_std = 0.005;    ///< rad
  double fixed_velocity_std = 0.1;      ///< m/s
  double fixed_gyro_bias_std = 1e-4;    ///< rad/s
  double fixed_accel_bias_std = 1e-3;   ///< m/s²
  double fixed_prior_interval = 0.1;    ///< s: the scan period the fixed prior is carried over

  void load(ConfigNode& node);
};

/// How the gyro reading changed across a step (its last sample less its first; the history
/// passes its low-passed readings, StateHistory::Entry::gyro_smooth). With the
/// LiDAR-IMU time offset t_d in the state, a step whose samples are placed δ too late reads
/// ω(t − δ) ≈ ω(t) − ω̇δ, so the step's attitude error carries ∂δθ'/∂δt_d = J_r·Δω: the offset
/// is seen where the rotation changes, through the propagated covariance. The velocity's term
/// R·Δf·δt_d is left out on purpose: under a vehicle's hard acceleration it let the offset take
/// up the velocity and accelerometer-bias errors of the first seconds (docs/architecture.md,
/// "LiDAR-IMU time offset"), and the attitude alone observes the offset.
struct ReadingChange {
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();
};

/// One IMU step of length dt with the (already averaged) measurement (gyro, accel).
/// When P is given it is propagated too.
void propagate(NavState& x, StateCovariance* P, const Eigen::Vector3d& gyro, const Eigen::Vector3d& accel,
               double dt, const ImuNoiseConfig& noise, const ReadingChange& change = {});

}  // namespace fuse

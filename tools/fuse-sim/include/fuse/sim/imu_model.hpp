// IMU measurement model (spec "Model"): gyro = w_body + b_g + n_g,
// accel = R_WI^T (a_W - g_W) + b_a + n_a, biases follow random walks. Discrete white noise
// sigma = density * sqrt(rate); bias random-walk step sigma = density / sqrt(rate).
// A vehicle's IMU also measures engine and road vibration (vibration.hpp), when enabled.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>

#include "fuse/core/types.hpp"
#include "fuse/sim/random.hpp"
#include "fuse/sim/trajectory.hpp"
#include "fuse/sim/vibration.hpp"

namespace fuse::sim {

/// Gravity in the world frame (z up).
inline const Eigen::Vector3d kGravityWorld(0.0, 0.0, -9.81);
/// Standard gravity, for converting micro-g densities.
constexpr double kStandardGravity = 9.81;
constexpr double kDegToRad = 0.017453292519943295;

/// ICM-40609-class defaults.
struct ImuNoiseConfig {
  double rate_hz = 200.0;
  double gyro_noise_density = 4.5e-3 * kDegToRad;            ///< rad/s/sqrt(Hz) (4.5 mdps/sqrt(Hz))
  double accel_noise_density = 100e-6 * kStandardGravity;    ///< m/s^2/sqrt(Hz) (100 ug/sqrt(Hz))
  double gyro_bias_random_walk = 2e-5;                       ///< rad/s^2/sqrt(Hz)
  double accel_bias_random_walk = 3e-4;                      ///< m/s^3/sqrt(Hz)
  double gyro_initial_bias_sigma = 0.3 * kDegToRad;          ///< rad/s, per axis
  double accel_initial_bias_sigma = 0.05;                    ///< m/s^2, per axis
  bool noise_enabled = true;                                 ///< false: ideal IMU (tests)
  bool bias_enabled = true;                                  ///< false: zero biases (tests)
  VibrationConfig vibration;                                 ///< enabled: a car's engine and road vibration
};

/// The ideal (noise- and bias-free) measurement of a trajectory state.
fuse::ImuSample ideal_imu(const TrajectoryState& state);

/// Stateful IMU: draws the initial biases, then one sample per call in time order.
class ImuSimulator {
 public:
  ImuSimulator(const ImuNoiseConfig& config, std::uint64_t seed);
  /// Measurement at the state's time (plus the vibration at the state's speed, if enabled), then
  /// advances the bias random walks by one period.
  fuse::ImuSample measure(const TrajectoryState& state);
  const Eigen::Vector3d& gyro_bias() const { return gyro_bias_; }
  const Eigen::Vector3d& accel_bias() const { return accel_bias_; }
  const Eigen::Vector3d& initial_gyro_bias() const { return initial_gyro_bias_; }
  const Eigen::Vector3d& initial_accel_bias() const { return initial_accel_bias_; }

 private:
  Eigen::Vector3d gaussian(double sigma);

  ImuNoiseConfig config_;
  Rng rng_;
  std::optional<Vibration> vibration_;
  Eigen::Vector3d gyro_bias_, accel_bias_, initial_gyro_bias_, initial_accel_bias_;
  std::uint64_t sequence_ = 0;
};

}  // namespace fuse::sim

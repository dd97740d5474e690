#include "fuse/sim/imu_model.hpp"

#include <cmath>
#include <stdexcept>

namespace fuse::sim {

fuse::ImuSample ideal_imu(const TrajectoryState& s) {
  fuse::ImuSample m;
  m.t = s.t;
  m.gyro = s.omega_body;
  m.accel = s.R.transpose() * (s.a - kGravityWorld);  // specific force in the body frame
  return m;
}

ImuSimulator::ImuSimulator(const ImuNoiseConfig& config, std::uint64_t seed)
    : config_(config), rng_(seed, Stream::kImu) {
  if (!(config.rate_hz > 0.0) || config.gyro_noise_density < 0.0 || config.accel_noise_density < 0.0 ||
      config.gyro_bias_random_walk < 0.0 || config.accel_bias_random_walk < 0.0)
    throw std::invalid_argument("IMU: rate must be positive and noise densities non-negative");
  gyro_bias_ = config.bias_enabled ? gaussian(config.gyro_initial_bias_sigma) : Eigen::Vector3d::Zero();
  accel_bias_ = config.bias_enabled ? gaussian(config.accel_initial_bias_sigma) : Eigen::Vector3d::Zero();
  initial_gyro_bias_ = gyro_bias_;
  initial_accel_bias_ = accel_bias_;
  if (config.vibration.enabled) vibration_.emplace(config.vibration, config.rate_hz, seed);
}

Eigen::Vector3d ImuSimulator::gaussian(double sigma) {
  const double x = rng_.normal(sigma), y = rng_.normal(sigma), z = rng_.normal(sigma);
  return {x, y, z};
}

fuse::ImuSample ImuSimulator::measure(const TrajectoryState& state) {
  fuse::ImuSample m = ideal_imu(state);
  m.sequence = sequence_++;
  m.gyro += gyro_bias_;
  m.accel += accel_bias_;
  if (vibration_) {
    Eigen::Vector3d accel, gyro;
    vibration_->next(state.v.norm(), accel, gyro);
    m.accel += accel;
    m.gyro += gyro;
  }
  if (config_.noise_enabled) {
    const double sqrt_rate = std::sqrt(config_.rate_hz);
    m.gyro += gaussian(config_.gyro_noise_density * sqrt_rate);
    m.accel += gaussian(config_.accel_noise_density * sqrt_rate);
    if (config_.bias_enabled) {
      gyro_bias_ += gaussian(config_.gyro_bias_random_walk / sqrt_rate);
      accel_bias_ += gaussian(config_.accel_bias_random_walk / sqrt_rate);
    }
  }
  return m;
}

}  // namespace fuse::sim

// Vehicle vibration felt by an IMU bolted to a car body. It is added to the IMU measurements only:
// its displacements are micrometres (0.3 m/s^2 at 30 Hz moves 8 um), so the ground truth ignores it.
//  - Engine: a few sinusoids whose frequencies rise with speed from idle (25-29.5 Hz) by up to
//    35 % (about 40 Hz at the reference speed: the engine turning faster within a gear), their
//    amplitude growing from an idle share to full at the reference speed. Mostly vertical in the
//    accelerometer, with a small angular-rate part (the mount rocking).
//  - Road: band-limited noise, white noise through a second-order band-pass around 12 Hz (wheel
//    hop and tyre / road texture), its RMS proportional to the speed (zero at rest).
// The parameters are drawn from the --seed's vibration stream and the road noise from its own
// stream, so the IMU's white noise and biases are those of a run without vibration.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "fuse/sim/random.hpp"

namespace fuse::sim {

/// One engine sinusoid: a sin(phase(t) + phase0) per axis, phase' = 2 pi f(speed).
struct EngineComponent {
  double idle_hz = 25.0;                                      ///< frequency at rest
  Eigen::Vector3d accel_amplitude = Eigen::Vector3d::Zero();  ///< m/s^2 per IMU axis, full load
  Eigen::Vector3d gyro_amplitude = Eigen::Vector3d::Zero();   ///< rad/s per IMU axis, full load
  double phase = 0.0;                                         ///< radians at the first sample
};

struct VibrationConfig {
  bool enabled = false;
  double reference_speed_mps = 20.0;  ///< speed of full engine amplitude and of the road RMS below
  double engine_rise = 0.35;          ///< engine frequencies at the reference speed: idle * (1 + rise)
  double idle_share = 0.6;            ///< engine amplitude at rest / at the reference speed
  std::vector<EngineComponent> engine;
  double road_center_hz = 12.0;                              ///< band-pass centre of the road noise
  double road_q = 0.7;                                       ///< band-pass quality factor (bandwidth = centre / Q)
  Eigen::Vector3d road_accel_rms = Eigen::Vector3d::Zero();  ///< m/s^2 per axis at the reference speed
  Eigen::Vector3d road_gyro_rms = Eigen::Vector3d::Zero();   ///< rad/s per axis at the reference speed
};

/// A car's vibration: three engine components and road noise, drawn from (seed, Stream::kVibration).
VibrationConfig vehicle_vibration(std::uint64_t seed);

/// Stateful vibration signal: one call per IMU sample, in time order.
class Vibration {
 public:
  /// Throws std::invalid_argument on a bad configuration (non-positive rate, frequency above
  /// Nyquist, negative amplitude).
  Vibration(const VibrationConfig& config, double rate_hz, std::uint64_t seed);
  /// The vibration of the next sample at this speed (m/s): added specific force and angular rate.
  void next(double speed, Eigen::Vector3d& accel, Eigen::Vector3d& gyro);

 private:
  /// Second-order band-pass (direct form I), unit output RMS for unit white input.
  struct BandPass {
    double b0 = 0.0, b2 = 0.0, a1 = 0.0, a2 = 0.0;
    double x1 = 0.0, x2 = 0.0, y1 = 0.0, y2 = 0.0;
    double step(double x);
  };

  VibrationConfig config_;
  double rate_hz_;
  Rng rng_;
  std::vector<double> phase_;  ///< accumulated engine phase per component (radians, below 2 pi)
  BandPass road_[6];           ///< accel x y z, gyro x y z
  double road_gain_ = 1.0;     ///< normalises the band-pass output to unit RMS
};

}  // namespace fuse::sim

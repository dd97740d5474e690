#include "fuse/sim/vibration.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace fuse::sim {

namespace {
constexpr double kTwoPi = 6.283185307179586476925286766559;

// A car's engine and road vibration (vehicle_vibration): ranges of the drawn parameters.
constexpr int kEngineComponents = 3;
constexpr double kEngineIdleHzMin = 25.0, kEngineIdleHzMax = 29.5;      // * 1.35 at speed: at most ~40 Hz
constexpr double kEngineAccelMin = 0.10, kEngineAccelMax = 0.20;        // m/s^2 per component, vertical
constexpr double kEngineLongShareMin = 0.3, kEngineLongShareMax = 0.6;  // x amplitude / vertical
constexpr double kEngineLatShareMin = 0.2, kEngineLatShareMax = 0.5;    // y amplitude / vertical
constexpr double kEngineGyroMin = 0.004, kEngineGyroMax = 0.010;        // rad/s per component, pitch axis
constexpr double kEngineRollShareMin = 0.6, kEngineRollShareMax = 1.0;
constexpr double kEngineYawShareMin = 0.2, kEngineYawShareMax = 0.4;
constexpr double kRoadAccelVerticalMin = 0.12, kRoadAccelVerticalMax = 0.20;  // m/s^2 RMS at 20 m/s
constexpr double kRoadAccelHorizontalMin = 0.04, kRoadAccelHorizontalMax = 0.08;
constexpr double kRoadGyroTiltMin = 0.003, kRoadGyroTiltMax = 0.006;  // rad/s RMS about x and y
constexpr double kRoadGyroYawMin = 0.001, kRoadGyroYawMax = 0.002;

// Above the reference speed the road noise keeps growing, up to this multiple.
constexpr double kMaxRoadLoad = 1.5;
// Samples of the band-pass impulse response summed for its noise gain (it decays within ~100).
constexpr int kGainSamples = 8000;
}  // namespace

VibrationConfig vehicle_vibration(std::uint64_t seed) {
  Rng rng(seed, Stream::kVibration);
  VibrationConfig c;
  c.enabled = true;
  for (int k = 0; k < kEngineComponents; ++k) {
    EngineComponent e;
    e.idle_hz = rng.uniform(kEngineIdleHzMin, kEngineIdleHzMax);
    const double vertical = rng.uniform(kEngineAccelMin, kEngineAccelMax);
    const double along = rng.uniform(kEngineLongShareMin, kEngineLongShareMax);
    const double across = rng.uniform(kEngineLatShareMin, kEngineLatShareMax);
    e.accel_amplitude = {along * vertical, across * vertical, vertical};
    const double tilt = rng.uniform(kEngineGyroMin, kEngineGyroMax);
    const double roll = rng.uniform(kEngineRollShareMin, kEngineRollShareMax);
    const double yaw = rng.uniform(kEngineYawShareMin, kEngineYawShareMax);
    e.gyro_amplitude = {roll * tilt, tilt, yaw * tilt};
    e.phase = rng.uniform(0.0, kTwoPi);
    c.engine.push_back(e);
  }
  const double ax = rng.uniform(kRoadAccelHorizontalMin, kRoadAccelHorizontalMax);
  const double ay = rng.uniform(kRoadAccelHorizontalMin, kRoadAccelHorizontalMax);
  const double az = rng.uniform(kRoadAccelVerticalMin, kRoadAccelVerticalMax);
  c.road_accel_rms = {ax, ay, az};
  const double gx = rng.uniform(kRoadGyroTiltMin, kRoadGyroTiltMax);
  const double gy = rng.uniform(kRoadGyroTiltMin, kRoadGyroTiltMax);
  const double gz = rng.uniform(kRoadGyroYawMin, kRoadGyroYawMax);
  c.road_gyro_rms = {gx, gy, gz};
  return c;
}

double Vibration::BandPass::step(double x) {
  const double y = b0 * x + b2 * x2 - a1 * y1 - a2 * y2;  // b1 = 0 for a band-pass
  x2 = x1;
  x1 = x;
  y2 = y1;
  y1 = y;
  return y;
}

Vibration::Vibration(const VibrationConfig& config, double rate_hz, std::uint64_t seed)
    : config_(config), rate_hz_(rate_hz), rng_(seed, Stream::kRoadNoise) {
  const double nyquist = 0.5 * rate_hz;
  if (!(rate_hz > 0.0) || !(config.reference_speed_mps > 0.0) || config.engine_rise < 0.0 || config.idle_share < 0.0 ||
      config.idle_share > 1.0 || !(config.road_center_hz > 0.0) || config.road_center_hz >= nyquist ||
      !(config.road_q > 0.0) || (config.road_accel_rms.array() < 0.0).any() ||
      (config.road_gyro_rms.array() < 0.0).any())
    throw std::invalid_argument("vibration: bad rate, reference speed, idle share or road band");
  for (const EngineComponent& e : config.engine) {
    if (!(e.idle_hz > 0.0) || e.idle_hz * (1.0 + config.engine_rise) >= nyquist ||
        (e.accel_amplitude.array() < 0.0).any() || (e.gyro_amplitude.array() < 0.0).any())
      throw std::invalid_argument("vibration: engine frequencies must stay below the Nyquist frequency");
    phase_.push_back(0.0);
  }
  // Band-pass with unit gain at the centre: H(z) = alpha (1 - z^-2) / ((1 + alpha) - 2 cos w0 z^-1
  // + (1 - alpha) z^-2), alpha = sin(w0) / 2Q, normalised by (1 + alpha).
  const double w0 = kTwoPi * config.road_center_hz / rate_hz, alpha = std::sin(w0) / (2.0 * config.road_q);
  BandPass filter;
  filter.b0 = alpha / (1.0 + alpha);
  filter.b2 = -filter.b0;
  filter.a1 = -2.0 * std::cos(w0) / (1.0 + alpha);
  filter.a2 = (1.0 - alpha) / (1.0 + alpha);
  for (BandPass& f : road_) f = filter;
  // White noise of unit variance comes out with variance sum h[n]^2 (h: impulse response).
  BandPass probe = filter;
  double energy = 0.0;
  for (int n = 0; n < kGainSamples; ++n) {
    const double h = probe.step(n == 0 ? 1.0 : 0.0);
    energy += h * h;
  }
  road_gain_ = 1.0 / std::sqrt(energy);
}

void Vibration::next(double speed, Eigen::Vector3d& accel, Eigen::Vector3d& gyro) {
  const double load = std::clamp(speed / config_.reference_speed_mps, 0.0, kMaxRoadLoad);
  const double engine_load = std::min(load, 1.0);
  const double amplitude = config_.idle_share + (1.0 - config_.idle_share) * engine_load;
  const double frequency_scale = 1.0 + config_.engine_rise * engine_load;
  accel.setZero();
  gyro.setZero();
  for (std::size_t k = 0; k < config_.engine.size(); ++k) {
    const EngineComponent& e = config_.engine[k];
    const double s = std::sin(phase_[k] + e.phase);
    accel += amplitude * s * e.accel_amplitude;
    gyro += amplitude * s * e.gyro_amplitude;
    // The phase advances by the current frequency over one sample period (kept below one turn).
    phase_[k] = std::fmod(phase_[k] + kTwoPi * e.idle_hz * frequency_scale / rate_hz_, kTwoPi);
  }
  // Six normal draws per sample, at rest too, so the sequence never depends on the motion.
  for (int i = 0; i < 6; ++i) {
    const double y = road_gain_ * road_[i].step(rng_.normal());
    if (i < 3)
      accel[i] += load * config_.road_accel_rms[i] * y;
    else
      gyro[i - 3] += load * config_.road_gyro_rms[i - 3] * y;
  }
}

}  // namespace fuse::sim

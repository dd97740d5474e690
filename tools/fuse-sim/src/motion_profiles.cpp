#include "fuse/sim/motion_profiles.hpp"

#include "fuse/sim/imu_model.hpp"  // kDegToRad

namespace fuse::sim {

namespace {
constexpr double kTwoPi = 6.283185307179586476925286766559;

// Amplitude, then frequency, then phase: drawn in a fixed order (argument evaluation order is
// unspecified in C++, so no draw happens inside a call's argument list).
Oscillation draw(Rng& rng, double amp_lo, double amp_hi, double freq_lo, double freq_hi) {
  Oscillation o;
  o.amplitude = rng.uniform(amp_lo, amp_hi);
  o.frequency_hz = rng.uniform(freq_lo, freq_hi);
  o.phase = rng.uniform(0.0, kTwoPi);
  return o;
}
Oscillation draw(Rng& rng, double amp_lo, double amp_hi, double freq_hz) {
  return draw(rng, amp_lo, amp_hi, freq_hz, freq_hz);
}

// Walking gait ranges (spec: bob ~2-3 cm at ~1.8-2 Hz, sway ~2 cm, roll/pitch 1-3 deg).
constexpr double kStepHzMin = 1.8, kStepHzMax = 2.0;
constexpr double kBobMin = 0.02, kBobMax = 0.03;
constexpr double kSwayMin = 0.015, kSwayMax = 0.025;
constexpr double kRollDegMin = 1.0, kRollDegMax = 2.5;
constexpr double kPitchDegMin = 1.0, kPitchDegMax = 2.0;
constexpr double kYawDegMin = 1.0, kYawDegMax = 2.0;
constexpr double kLookAroundHz = 0.15;      // slow head-like yaw drift
constexpr double kLookAroundDegMax = 3.0;
}  // namespace

MotionConfig walking_motion(Rng& rng) {
  const double step_hz = rng.uniform(kStepHzMin, kStepHzMax);
  MotionConfig m;
  m.vertical = {draw(rng, kBobMin, kBobMax, step_hz)};
  m.lateral = {draw(rng, kSwayMin, kSwayMax, 0.5 * step_hz)};
  m.roll = {draw(rng, kRollDegMin * kDegToRad, kRollDegMax * kDegToRad, 0.5 * step_hz)};
  m.pitch = {draw(rng, kPitchDegMin * kDegToRad, kPitchDegMax * kDegToRad, step_hz)};
  m.yaw.push_back(draw(rng, kYawDegMin * kDegToRad, kYawDegMax * kDegToRad, 0.5 * step_hz));
  m.yaw.push_back(draw(rng, 0.0, kLookAroundDegMax * kDegToRad, kLookAroundHz));
  return m;
}

MotionConfig aggressive_handheld_motion(Rng& rng) {
  MotionConfig m = walking_motion(rng);
  // Large swings whose peak rates a * 2 pi f reach 180-300 deg/s.
  m.yaw.push_back(draw(rng, 50.0 * kDegToRad, 70.0 * kDegToRad, 0.6, 0.8));
  m.pitch.push_back(draw(rng, 25.0 * kDegToRad, 35.0 * kDegToRad, 0.8, 1.0));
  m.roll.push_back(draw(rng, 20.0 * kDegToRad, 30.0 * kDegToRad, 1.0, 1.3));
  return m;
}

MotionConfig vehicle_motion(Rng& rng) {
  MotionConfig m;
  m.vertical = {draw(rng, 0.005, 0.015, 1.2, 1.6)};
  m.lateral = {draw(rng, 0.03, 0.08, 0.08, 0.12)};
  m.roll = {draw(rng, 0.3 * kDegToRad, 0.8 * kDegToRad, 0.7, 0.9)};
  m.pitch = {draw(rng, 0.2 * kDegToRad, 0.6 * kDegToRad, 1.0, 1.3)};
  m.yaw = {draw(rng, 0.2 * kDegToRad, 0.8 * kDegToRad, 0.25, 0.35)};
  return m;
}

}  // namespace fuse::sim

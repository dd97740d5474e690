#include "fuse/sim/time_law.hpp"

#include <cmath>
#include <stdexcept>

namespace fuse::sim {

namespace {
// Septic smoothstep and its integral and derivatives on x in [0, 1].
double smooth(double x) { return x * x * x * x * (35.0 - 84.0 * x + 70.0 * x * x - 20.0 * x * x * x); }
double smooth_integral(double x) {  // int_0^x S, equals 1/2 at x = 1
  const double x5 = x * x * x * x * x;
  return x5 * (7.0 - 14.0 * x + 10.0 * x * x - 2.5 * x * x * x);
}
double smooth_d1(double x) { return 140.0 * x * x * x * (1.0 - x) * (1.0 - x) * (1.0 - x); }
double smooth_d2(double x) {  // d/dx of 140 x^3 (1-x)^3 = 420 x^2 (1-x)^2 (1 - 2x)
  return 420.0 * x * x * (1.0 - x) * (1.0 - x) * (1.0 - 2.0 * x);
}
}  // namespace

TimeLaw::TimeLaw(const TimeLawConfig& config, double u_end) : config_(config), u_end_(u_end) {
  if (!(config.rate > 0.0) || !(config.ramp_s > 0.0) || config.rest_start_s < 0.0 ||
      config.rest_end_s < 0.0 || !(u_end > 0.0))
    throw std::invalid_argument("time law: rate, ramp and path length must be positive, rests >= 0");
  // Each ramp covers rate * ramp / 2 of the path (the smoothstep averages 1/2).
  cruise_s_ = (u_end - config.rate * config.ramp_s) / config.rate;
  if (cruise_s_ < 0.0) throw std::invalid_argument("time law: path too short for the speed ramps");
  t_stop_ = config.rest_start_s + 2.0 * config.ramp_s + cruise_s_;
}

TimeLawSample TimeLaw::at(double t) const {
  const double v = config_.rate, T = config_.ramp_s;
  const double t_ramp_up = config_.rest_start_s, t_cruise = t_ramp_up + T;
  const double t_ramp_down = t_cruise + cruise_s_;
  if (t <= t_ramp_up) return {0.0, 0.0, 0.0, 0.0};
  if (t < t_cruise) {  // u' = v S(x), x = (t - t_ramp_up) / T
    const double x = (t - t_ramp_up) / T;
    return {v * T * smooth_integral(x), v * smooth(x), v * smooth_d1(x) / T, v * smooth_d2(x) / (T * T)};
  }
  const double u_cruise = 0.5 * v * T;
  if (t <= t_ramp_down) return {u_cruise + v * (t - t_cruise), v, 0.0, 0.0};
  if (t < t_stop_) {  // mirror image: u' = v S(1 - x), u = u_end - v T int_0^{1-x} S
    const double y = 1.0 - (t - t_ramp_down) / T;
    return {u_end_ - v * T * smooth_integral(y), v * smooth(y), -v * smooth_d1(y) / T,
            v * smooth_d2(y) / (T * T)};
  }
  return {u_end_, 0.0, 0.0, 0.0};
}

}  // namespace fuse::sim

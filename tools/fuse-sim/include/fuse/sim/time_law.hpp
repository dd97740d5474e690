// The path parameter as a function of time, u(t): at rest, a smooth ramp up to the cruise rate,
// cruise, a smooth ramp down that stops exactly at the end of the path, at rest again.
// The ramps use the septic smoothstep S(x) = 35x^4 - 84x^5 + 70x^6 - 20x^7 (S', S'', S''' vanish
// at both ends), so u is C4 in time and the motion starts and stops without jerk steps.
#pragma once

namespace fuse::sim {

struct TimeLawConfig {
  double rest_start_s = 3.0;  ///< exactly at rest before moving
  double ramp_s = 2.0;        ///< duration of each speed ramp
  double rate = 1.3;          ///< cruise rate du/dt (m/s on straight segments)
  double rest_end_s = 2.0;    ///< exactly at rest after stopping
};

/// u(t) and its first three time derivatives.
struct TimeLawSample {
  double u = 0.0, u1 = 0.0, u2 = 0.0, u3 = 0.0;
};

class TimeLaw {
 public:
  /// Throws std::invalid_argument if the path is too short for the two ramps or a value is bad.
  TimeLaw(const TimeLawConfig& config, double u_end);
  TimeLawSample at(double t_rel) const;  ///< t_rel: seconds since the trajectory start
  double duration() const { return t_stop_ + config_.rest_end_s; }
  double cruise_duration() const { return cruise_s_; }
  const TimeLawConfig& config() const { return config_; }

 private:
  TimeLawConfig config_;
  double u_end_ = 0.0, cruise_s_ = 0.0, t_stop_ = 0.0;
};

}  // namespace fuse::sim

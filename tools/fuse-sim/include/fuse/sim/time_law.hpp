// The path parameter as a function of time, u(t): at rest, a smooth ramp up to the cruise rate,
// cruise, a smooth ramp down that stops exactly at the end of the path, at rest again.
// The ramps use the septic smoothstep S(x) = 35x^4 - 84x^5 + 70x^6 - 20x^7 (S', S'', S''' vanish
// at both ends), so u is C4 in time and the motion starts and stops without jerk steps.
//
// With speed limits (a vehicle slowing down for corners) the law is a schedule of phases instead:
// holds at a constant rate and smoothstep changes between rates, each change taking as long as
// its peak acceleration (35/16 of the mean) allows. Between two limited stretches the rate rises
// as far as the distance allows (at most the cruise rate) and falls again in time for the next.
// A stop is a stretch of rate 0 and no length, held for its dwell time (a car at a stop line).
#pragma once

#include <vector>

namespace fuse::sim {

/// The stretch of path [u_begin, u_end] (e.g. a corner and its approach) is driven at no more
/// than `rate`.
struct SpeedLimit {
  double u_begin = 0.0, u_end = 0.0;
  double rate = 0.0;
};

/// The scheduled law comes to rest at path parameter `u` (a stop line) and waits there for
/// `dwell_s` seconds before it drives on.
struct Stop {
  double u = 0.0;
  double dwell_s = 0.0;
};

struct TimeLawConfig {
  double rest_start_s = 3.0;  ///< exactly at rest before moving
  double ramp_s = 2.0;        ///< duration of each speed ramp (without speed limits)
  double rate = 1.3;          ///< cruise rate du/dt (m/s on straight segments); with limits the top rate
  double rest_end_s = 2.0;    ///< exactly at rest after stopping
  /// Empty: the rest-ramp-cruise-ramp-rest law. Otherwise the scheduled law (file comment); the
  /// limits may come in any order and overlap (the lower rate wins).
  std::vector<SpeedLimit> limits;
  /// Stops of the scheduled law (it needs limits); none may lie inside a limited stretch.
  std::vector<Stop> stops;
  double max_accel = 2.5;  ///< m/s^2, peak |u''| of every rate change of the scheduled law

  /// The same law for the path from parameter u0 on (Path::from): the limits and stops shifted
  /// by -u0, those wholly behind the new start dropped.
  TimeLawConfig from(double u0) const;
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
  double cruise_duration() const { return cruise_s_; }  ///< time at the cruise rate
  const TimeLawConfig& config() const { return config_; }

  /// One phase of the scheduled law: u' = r0 + (r1 - r0) S((t - t_begin) / duration).
  struct Phase {
    double t_begin = 0.0, duration = 0.0, u_begin = 0.0;
    double r0 = 0.0, r1 = 0.0;
  };
  /// The scheduled law's phases in time order (empty without speed limits).
  const std::vector<Phase>& phases() const { return phases_; }

 private:
  void plan(double u_end);
  TimeLawSample scheduled(double t_rel) const;

  TimeLawConfig config_;
  double u_end_ = 0.0, cruise_s_ = 0.0, t_stop_ = 0.0;
  std::vector<Phase> phases_;
};

}  // namespace fuse::sim

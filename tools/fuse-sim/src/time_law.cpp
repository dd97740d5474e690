#include "fuse/sim/time_law.hpp"

#include <algorithm>
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

// The peak of S' (at x = 1/2): a rate change dr over T seconds peaks at u'' = kSmoothPeakSlope dr / T.
constexpr double kSmoothPeakSlope = 35.0 / 16.0;
// Scheduled phases shorter than this (seconds or metres) are left out.
constexpr double kNegligible = 1e-9;
}  // namespace

TimeLawConfig TimeLawConfig::from(double u0) const {
  TimeLawConfig c = *this;
  if (limits.empty()) return c;
  c.limits.clear();
  for (const SpeedLimit& l : limits)
    if (l.u_end > u0) c.limits.push_back({std::max(0.0, l.u_begin - u0), l.u_end - u0, l.rate});
  c.stops.clear();
  for (const Stop& s : stops)
    if (s.u > u0) c.stops.push_back({s.u - u0, s.dwell_s});
  // No limit left ahead: one that never binds keeps the law scheduled (same accelerations).
  if (c.limits.empty()) c.limits.push_back({0.0, 0.0, rate});
  return c;
}

TimeLaw::TimeLaw(const TimeLawConfig& config, double u_end) : config_(config), u_end_(u_end) {
  if (!config.limits.empty()) {
    if (!(config.rate > 0.0) || config.rest_start_s < 0.0 || config.rest_end_s < 0.0 || !(u_end > 0.0) ||
        !std::isfinite(config.rate) || !std::isfinite(u_end))
      throw std::invalid_argument("time law: rate and path length must be positive, rests >= 0");
    plan(u_end);
    return;
  }
  if (!(config.rate > 0.0) || !(config.ramp_s > 0.0) || config.rest_start_s < 0.0 ||
      config.rest_end_s < 0.0 || !(u_end > 0.0))
    throw std::invalid_argument("time law: rate, ramp and path length must be positive, rests >= 0");
  // Each ramp covers rate * ramp / 2 of the path (the smoothstep averages 1/2).
  cruise_s_ = (u_end - config.rate * config.ramp_s) / config.rate;
  if (cruise_s_ < 0.0) throw std::invalid_argument("time law: path too short for the speed ramps");
  t_stop_ = config.rest_start_s + 2.0 * config.ramp_s + cruise_s_;
}

void TimeLaw::plan(double u_end) {
  const double top = config_.rate, accel = config_.max_accel;
  if (!(accel > 0.0) || !std::isfinite(accel)) throw std::invalid_argument("time law: max_accel must be positive");
  // A change between rates r0 and r1 takes k |r1 - r0| / a seconds and covers k |r1^2 - r0^2| / 2a.
  const auto change_time = [&](double r0, double r1) { return kSmoothPeakSlope * std::abs(r1 - r0) / accel; };
  const auto change_distance = [&](double r0, double r1) {
    return kSmoothPeakSlope * std::abs(r1 * r1 - r0 * r0) / (2.0 * accel);
  };
  // The rate reachable from r0 over a distance d (inverse of change_distance).
  const auto reachable = [&](double r0, double d) { return std::sqrt(r0 * r0 + 2.0 * accel * d / kSmoothPeakSlope); };

  // 1. The limited stretches: checked, kept clear of the distance needed to reach their rate from
  // rest at the start and to stop from it at the end, sorted and merged where they overlap.
  struct Stretch {
    double begin, end, rate;
    double dwell = 0.0;  ///< s held at rest (a stop)
  };
  std::vector<Stretch> stretches;
  for (const SpeedLimit& l : config_.limits) {
    if (!std::isfinite(l.u_begin) || !std::isfinite(l.u_end) || !std::isfinite(l.rate) || !(l.rate > 0.0) ||
        l.u_end < l.u_begin)
      throw std::invalid_argument("time law: a speed limit needs finite u_begin <= u_end and a positive rate");
    if (l.rate >= top) continue;  // never binds
    const double margin = change_distance(0.0, l.rate);
    const double begin = std::max(l.u_begin, margin), end = std::min(l.u_end, u_end - margin);
    if (begin <= end) stretches.push_back({begin, end, l.rate});
  }
  std::sort(stretches.begin(), stretches.end(), [](const Stretch& a, const Stretch& b) { return a.begin < b.begin; });
  std::vector<Stretch> anchors = {{0.0, 0.0, 0.0}};  // at rest at the start ...
  for (const Stretch& s : stretches) {
    if (anchors.size() > 1 && s.begin <= anchors.back().end) {
      anchors.back().end = std::max(anchors.back().end, s.end);
      anchors.back().rate = std::min(anchors.back().rate, s.rate);
    } else {
      anchors.push_back(s);
    }
  }
  for (const Stop& stop : config_.stops) {
    if (!std::isfinite(stop.u) || !(stop.u > 0.0) || !(stop.u < u_end) || !std::isfinite(stop.dwell_s) ||
        stop.dwell_s < 0.0)
      throw std::invalid_argument("time law: a stop needs 0 < u < the path's end and a dwell >= 0");
    for (std::size_t k = 1; k < anchors.size(); ++k) {
      if (stop.u >= anchors[k].begin && stop.u <= anchors[k].end)
        throw std::invalid_argument("time law: a stop lies inside a limited stretch");
    }
    anchors.push_back({stop.u, stop.u, 0.0, stop.dwell_s});
  }
  std::sort(anchors.begin() + 1, anchors.end(), [](const Stretch& a, const Stretch& b) { return a.begin < b.begin; });
  anchors.push_back({u_end, u_end, 0.0});  // ... and at the end

  // 2. Rates that the neighbours can reach or leave in the distance between (forward and backward
  // passes, as in any speed planner).
  for (std::size_t k = 1; k < anchors.size(); ++k)
    anchors[k].rate = std::min(anchors[k].rate, reachable(anchors[k - 1].rate, anchors[k].begin - anchors[k - 1].end));
  for (std::size_t k = anchors.size() - 1; k-- > 0;)
    anchors[k].rate = std::min(anchors[k].rate, reachable(anchors[k + 1].rate, anchors[k + 1].begin - anchors[k].end));

  // 3. Phases: each stretch held at its rate; between two, up to the highest rate the distance
  // allows (at most the top rate), held, and down again.
  double t = config_.rest_start_s, u = 0.0;
  const auto change = [&](double r0, double r1) {
    const double T = change_time(r0, r1);
    if (T <= kNegligible) return;
    phases_.push_back({t, T, u, r0, r1});
    t += T;
    u += 0.5 * T * (r0 + r1);
  };
  const auto hold = [&](double r, double distance) {
    if (distance <= kNegligible) return;
    const double T = distance / r;
    phases_.push_back({t, T, u, r, r});
    if (r == top) cruise_s_ += T;
    t += T;
    u += distance;
  };
  for (std::size_t k = 0; k + 1 < anchors.size(); ++k) {
    const Stretch& a = anchors[k];
    const Stretch& b = anchors[k + 1];
    if (k > 0 && a.rate > 0.0) hold(a.rate, a.end - a.begin);
    if (k > 0 && a.dwell > 0.0) {  // at rest at a stop
      phases_.push_back({t, a.dwell, u, 0.0, 0.0});
      t += a.dwell;
    }
    const double gap = b.begin - a.end;
    const double peak = std::max(
        std::min(top, std::sqrt(0.5 * (2.0 * accel * gap / kSmoothPeakSlope + a.rate * a.rate + b.rate * b.rate))),
        std::max(a.rate, b.rate));
    change(a.rate, peak);
    hold(peak, gap - change_distance(a.rate, peak) - change_distance(peak, b.rate));
    change(peak, b.rate);
  }
  t_stop_ = t;
}

TimeLawSample TimeLaw::scheduled(double t) const {
  if (phases_.empty() || t <= phases_.front().t_begin) return {0.0, 0.0, 0.0, 0.0};
  if (t >= t_stop_) return {u_end_, 0.0, 0.0, 0.0};
  const auto it = std::upper_bound(phases_.begin(), phases_.end(), t,
                                   [](double time, const Phase& p) { return time < p.t_begin; });
  const Phase& p = *(it - 1);
  const double tau = t - p.t_begin;
  if (p.r0 == p.r1) return {std::min(u_end_, p.u_begin + p.r0 * tau), p.r0, 0.0, 0.0};
  const double T = p.duration, x = std::clamp(tau / T, 0.0, 1.0), dr = p.r1 - p.r0;
  return {std::min(u_end_, p.u_begin + p.r0 * tau + dr * T * smooth_integral(x)), p.r0 + dr * smooth(x),
          dr * smooth_d1(x) / T, dr * smooth_d2(x) / (T * T)};
}

TimeLawSample TimeLaw::at(double t) const {
  if (!config_.limits.empty()) return scheduled(t);
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

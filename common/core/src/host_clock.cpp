#include "fuse/core/host_clock.hpp"

#include <cmath>
#include <ctime>

namespace fuse {

namespace {
double read(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}
}  // namespace

HostClockMap::HostClockMap(double window_s) : window_s_(window_s) {}

void HostClockMap::observe(double t_sensor, double t_monotonic) {
  if (!std::isfinite(t_sensor) || !std::isfinite(t_monotonic)) return;
  const double offset = t_monotonic - t_sensor;
  if (!samples_.empty() && t_sensor < samples_.back().t_sensor) {
    // Older than the newest: re-delivered or out of order (it came late, so it cannot be the
    // fastest), unless it is a window or more behind: the clock stepped back, and the samples
    // ahead of it are on a time base that no longer holds.
    if (t_sensor > samples_.back().t_sensor - window_s_) return;
    samples_.clear();
  }
  while (!samples_.empty() && samples_.back().offset >= offset) samples_.pop_back();
  samples_.push_back({t_sensor, offset});
  while (samples_.front().t_sensor < t_sensor - window_s_) samples_.pop_front();
}

void HostClockMap::observe_now(double t_sensor) { observe(t_sensor, now_monotonic()); }

std::optional<HostClockOffsets> HostClockMap::offsets(double realtime_minus_monotonic) const {
  if (samples_.empty()) return std::nullopt;
  const double mono = samples_.front().offset;
  return HostClockOffsets{mono + realtime_minus_monotonic, mono};
}

std::optional<HostClockOffsets> HostClockMap::offsets_now() const { return offsets(read_realtime_minus_monotonic()); }

double HostClockMap::now_monotonic() { return read(CLOCK_MONOTONIC); }

double HostClockMap::read_realtime_minus_monotonic() { return read(CLOCK_REALTIME) - read(CLOCK_MONOTONIC); }

}  // namespace fuse

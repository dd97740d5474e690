// The mapping between the sensor clock (every stamp in FUSE) and the host's clocks, for planners
// that know only the host's time.
//
// Each arriving sample gives one measurement of the offset o = t_host,arrival − t_sensor, which
// is the true offset plus the sample's latency (driver, ingestion, transport: never negative).
// The smallest o over the last `window_s` of sensor time is the sample that came through
// fastest: its latency bounds the mapping's error. A window, not the minimum of all time, so
// that a drifting sensor clock or a re-based one is followed within a window. Kept on
// CLOCK_MONOTONIC (it does not step); the CLOCK_REALTIME offset is the monotonic one plus
// realtime − monotonic read now, so an NTP step of the host shows in it at once.
#pragma once

#include <deque>
#include <optional>

namespace fuse {

struct HostClockOffsets {
  double realtime = 0.0;   ///< t_realtime = t_sensor + realtime
  double monotonic = 0.0;  ///< t_monotonic = t_sensor + monotonic
};

class HostClockMap {
 public:
  /// Longest sensor time span the minimum is taken over.
  static constexpr double kDefaultWindowS = 10.0;

  explicit HostClockMap(double window_s = kDefaultWindowS);

  /// A sample stamped t_sensor arrived at t_monotonic on the host (seconds). Non-finite values
  /// are ignored.
  void observe(double t_sensor, double t_monotonic);
  /// Reads the host's clocks now and observes t_sensor at that moment.
  void observe_now(double t_sensor);

  /// The offsets; std::nullopt before the first sample. realtime_minus_monotonic: the host's
  /// CLOCK_REALTIME − CLOCK_MONOTONIC at the moment of use (read_realtime_minus_monotonic()).
  std::optional<HostClockOffsets> offsets(double realtime_minus_monotonic) const;
  std::optional<HostClockOffsets> offsets_now() const;

  static double now_monotonic();
  static double read_realtime_minus_monotonic();

 private:
  struct Sample {
    double t_sensor;
    double offset;
  };
  double window_s_;
  /// Increasing offsets from front to back (a sliding-window minimum): the front is the minimum.
  std::deque<Sample> samples_;
};

}  // namespace fuse

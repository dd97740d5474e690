#include "fuse/launch/replay_progress.hpp"

#include "fuse/core/logging.hpp"

namespace fuse::launch {

namespace {
constexpr const char* kLogger = "launch";  // the launcher's own log lines
}  // namespace

ReplayProgress::ReplayProgress(std::optional<std::uint64_t> total_events, double period_s)
    : total_known_(total_events && *total_events > 0), progress_(kLogger, total_events, period_s) {}

void ReplayProgress::update(const ReplaySnapshot& s) { progress_.update(s.events, s.sensor_t, detail(s)); }

std::string ReplayProgress::line(const ReplaySnapshot& s, double wall_s) const {
  return progress_.line(s.events, s.sensor_t, wall_s, detail(s));
}

std::string ReplayProgress::detail(const ReplaySnapshot& s) const {
  std::string d = fmt::format("{} scans replayed, {} poses", s.scans, s.poses);
  if (!s.tracking.empty()) d += ", fuse-state " + s.tracking;
  // Progress gives no percentage or time left then: say why the line is shorter.
  if (!total_known_) d += ", input size unknown";
  return d;
}

std::string describe_replay_size(std::optional<std::uint64_t> total_events) {
  if (total_events && *total_events > 0) {
    return fmt::format("the input holds {} IMU samples and scans; progress lines count those fuse-ingest published",
                       *total_events);
  }
  return "the input does not say how many IMU samples and scans it holds (only an MCAP recording's statistics "
         "do): progress lines count those fuse-ingest published, without a percentage or time left";
}

}  // namespace fuse::launch

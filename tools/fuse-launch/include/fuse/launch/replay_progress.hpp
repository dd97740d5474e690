// fuse-launch's progress line while fuse-ingest replays a recording: what the launcher sees on the
// bus, logged by fuse::Progress (logger "launch", every few seconds). The launcher does not read
// the replay itself: the counts are fuse-ingest's health counters, the sensor time that of the
// scans fuse-update answered, the poses the corrected estimates fuse-state published.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "fuse/core/progress.hpp"

namespace fuse::launch {

/// What the launcher has seen of the replay so far.
struct ReplaySnapshot {
  std::uint64_t events = 0;  ///< IMU samples and scans fuse-ingest published
  std::uint64_t scans = 0;   ///< of those, scans
  std::uint64_t poses = 0;   ///< corrected estimates fuse-state published (one per trajectory pose)
  double sensor_t = -1.0;    ///< newest scan end time fuse-update answered (s); negative: none yet
  std::string tracking;      ///< fuse-state's health state; empty: not heard from yet
};

class ReplayProgress {
 public:
  /// total_events: the IMU samples and scans the input holds, when it says (an MCAP recording's
  /// statistics). The wall clock of the rate and the time left starts here.
  explicit ReplayProgress(std::optional<std::uint64_t> total_events, double period_s = 5.0);
  /// Call at every poll: logs a line once every period.
  void update(const ReplaySnapshot& s);
  /// The line update() would log after wall_s seconds (for tests).
  std::string line(const ReplaySnapshot& s, double wall_s) const;

 private:
  std::string detail(const ReplaySnapshot& s) const;

  bool total_known_;
  Progress progress_;
};

/// One line saying what the progress lines will count, and why they have no percentage when the
/// input's size is unknown.
std::string describe_replay_size(std::optional<std::uint64_t> total_events);

}  // namespace fuse::launch

// A progress line for long runs (fuse-run, fuse-import): one every `period_s` of wall clock, with
// the share done and the time left when the total is known, and the speed against real time when
// the work has a sensor time.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

namespace fuse {

class Progress {
 public:
  /// logger: the component's spdlog logger name; total: the work's size in items, when known.
  Progress(std::string logger, std::optional<std::uint64_t> total, double period_s = 5.0);
  /// done items so far; t: the sensor time reached (seconds) or a negative value when there is
  /// none; detail: appended to the line (e.g. the tracking status).
  void update(std::uint64_t done, double t, const std::string& detail = "");
  /// The line update() would log now (for tests).
  std::string line(std::uint64_t done, double t, double wall_s, const std::string& detail) const;

 private:
  std::string logger_;
  std::optional<std::uint64_t> total_;
  double period_s_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  double next_s_;
  double first_t_ = -1.0;
};

}  // namespace fuse

// Groups decoded Livox points into scans of a fixed period by their own times (the Mid-360
// sends points continuously, not in revolutions): scan k holds the points with
// t in [t0 + k * period, t0 + (k + 1) * period), t0 the first point's time. A scan is complete
// once a point at or past its end arrives; points older than the scan being filled (a late
// or reordered packet) are dropped and counted, as are returns at the origin (no echo).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "fuse/core/types.hpp"
#include "fuse/io/livox_packet.hpp"

namespace fuse::io::livox {

class ScanAssembler {
 public:
  /// Throws std::invalid_argument unless 0 < period_s.
  explicit ScanAssembler(double period_s);

  /// Adds a packet's points; complete scans are appended to `done` (in time order).
  void add(const std::vector<Point>& points, std::vector<LidarScan>& done);
  /// The scan being filled, if it has points (at the end of the input).
  std::optional<LidarScan> flush();

  std::uint64_t late_points() const { return late_; }
  std::uint64_t empty_returns() const { return empty_; }

 private:
  void start(std::uint64_t index);  ///< opens window `index` (from origin_)
  std::int64_t window(double t) const;  ///< the window holding time t

  double period_;
  bool started_ = false;
  double start_ = 0.0;  ///< current scan's start time
  std::uint64_t index_ = 0;
  double origin_ = 0.0;  ///< t0
  LidarScan current_;
  std::uint64_t late_ = 0, empty_ = 0, sequence_ = 0;
};

}  // namespace fuse::io::livox

#include "fuse/io/livox_scan_assembler.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace fuse::io::livox {

ScanAssembler::ScanAssembler(double period_s) : period_(period_s) {
  if (!(period_s > 0.0) || !std::isfinite(period_s)) {
    throw std::invalid_argument("Livox scan period " + std::to_string(period_s) + " s must be positive");
  }
}

namespace {
/// Points within this fraction of a period before a window boundary count as on it: a point
/// taken at the boundary's time (packets start on it every scan) must not fall on either side
/// depending on how its time and the boundary were rounded.
constexpr double kBoundaryTolerance = 1e-6;
}  // namespace

void ScanAssembler::start(std::uint64_t index) {
  index_ = index;
  start_ = origin_ + static_cast<double>(index) * period_;
  current_ = LidarScan{};
  current_.t_start = start_;
  current_.t_end = origin_ + static_cast<double>(index + 1) * period_;
}

std::int64_t ScanAssembler::window(double t) const {
  return static_cast<std::int64_t>(std::floor((t - origin_) / period_ + kBoundaryTolerance));
}

void ScanAssembler::add(const std::vector<Point>& points, std::vector<LidarScan>& done) {
  for (const Point& p : points) {
    if (p.x == 0.f && p.y == 0.f && p.z == 0.f) {  // no echo
      ++empty_;
      continue;
    }
    if (!started_) {
      started_ = true;
      origin_ = p.t;
      start(0);
    }
    // One rule decides a point's window, so a point exactly on a boundary opens the next scan.
    const std::int64_t w = window(p.t);
    if (w < static_cast<std::int64_t>(index_)) {
      ++late_;
      continue;
    }
    if (w > static_cast<std::int64_t>(index_)) {
      // Close the current scan (if it has points) and jump to the window holding p.
      if (!current_.points.empty()) {
        current_.sequence = sequence_++;
        done.push_back(std::move(current_));
      }
      start(static_cast<std::uint64_t>(w));
    }
    LidarPoint q;
    q.x = p.x;
    q.y = p.y;
    q.z = p.z;
    q.intensity = p.reflectivity;
    q.t_rel = static_cast<float>(std::max(0.0, p.t - start_));  // ≥ −tolerance: on the boundary
    q.ring = 0;  // the Mid-360 has no rings in its packets
    current_.points.push_back(q);
  }
}

std::optional<LidarScan> ScanAssembler::flush() {
  if (!started_ || current_.points.empty()) return std::nullopt;
  current_.sequence = sequence_++;
  LidarScan out = std::move(current_);
  start(index_ + 1);
  return out;
}

}  // namespace fuse::io::livox

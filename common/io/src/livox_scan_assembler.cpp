#include "fuse/io/livox_scan_assembler.hpp"

#include <cmath>
#include <stdexcept>

namespace fuse::io::livox {

ScanAssembler::ScanAssembler(double period_s) : period_(period_s) {
  if (!(period_s > 0.0) || !std::isfinite(period_s)) {
    throw std::invalid_argument("Livox scan period " + std::to_string(period_s) + " s must be positive");
  }
}

void ScanAssembler::start(double t_start) {
  start_ = t_start;
  current_ = LidarScan{};
  current_.t_start = t_start;
  current_.t_end = t_start + period_;
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
      index_ = 0;
      start(origin_);
    }
    if (p.t < start_) {
      ++late_;
      continue;
    }
    if (p.t >= current_.t_end) {
      // Close the current scan (if it has points) and jump to the window holding p.
      if (!current_.points.empty()) {
        current_.sequence = sequence_++;
        done.push_back(std::move(current_));
      }
      index_ = static_cast<std::uint64_t>(std::floor((p.t - origin_) / period_));
      start(origin_ + static_cast<double>(index_) * period_);
      if (p.t >= current_.t_end) start(current_.t_end);  // rounding at a window boundary
    }
    LidarPoint q;
    q.x = p.x;
    q.y = p.y;
    q.z = p.z;
    q.intensity = p.reflectivity;
    q.t_rel = static_cast<float>(p.t - start_);
    q.ring = 0;  // the Mid-360 has no rings in its packets
    current_.points.push_back(q);
  }
}

std::optional<LidarScan> ScanAssembler::flush() {
  if (!started_ || current_.points.empty()) return std::nullopt;
  current_.sequence = sequence_++;
  LidarScan out = std::move(current_);
  start(out.t_end);
  return out;
}

}  // namespace fuse::io::livox

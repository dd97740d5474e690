#include "fuse/service/scan_backlog.hpp"

#include <algorithm>

namespace fuse::service {

std::size_t ScanBacklog::push(LidarScan scan) {
  scans_.push_back(Held{std::move(scan), false});
  std::size_t dropped = 0;
  while (scans_.size() > 1 && span_s() > max_span_s_) {
    scans_.pop_front();
    ++dropped;
  }
  return dropped;
}

LidarScan ScanBacklog::take_front() {
  LidarScan scan = std::move(scans_.front().scan);
  scans_.pop_front();
  return scan;
}

void ScanBacklog::return_front(LidarScan scan) { scans_.push_front(Held{std::move(scan), false}); }

double ScanBacklog::span_s() const {
  if (scans_.empty()) return 0.0;
  return std::max(0.0, scans_.back().scan.t_end - scans_.front().scan.t_start);
}

std::size_t ScanBacklog::points() const {
  std::size_t n = 0;
  for (const Held& h : scans_) n += h.scan.points.size();
  return n;
}

std::size_t ScanBacklog::compact_waiting(std::size_t keep_raw) {
  std::size_t n = 0;
  for (std::size_t i = keep_raw; i < scans_.size(); ++i) {
    if (scans_[i].compacted) continue;
    compact(scans_[i].scan);
    scans_[i].compacted = true;
    ++n;
  }
  return n;
}

void ScanBacklog::compact(LidarScan& scan) {
  // The LiDAR step's first stage (LidarUpdater::process, step 1): range filter, then per voxel
  // of preprocess.voxel_size the point nearest the voxel centre. Running it again on the kept
  // points keeps them (each is nearest its own voxel's centre), so the step sees what it would
  // have kept from the raw scan; only its voxel growth (max_points) then picks among fewer.
  xyz_.clear();
  in_range_.clear();
  const PreprocessConfig::RangeGate gate = preprocess_.range_gate();
  for (std::uint32_t i = 0; i < scan.points.size(); ++i) {
    const LidarPoint& p = scan.points[i];
    const Eigen::Vector3f v(p.x, p.y, p.z);
    if (!gate.pass(v)) continue;
    xyz_.push_back(v);
    in_range_.push_back(i);
  }
  filter_.filter(xyz_, static_cast<float>(preprocess_.voxel_size), kept_);
  std::vector<LidarPoint> kept;
  kept.reserve(kept_.size());
  for (const std::uint32_t k : kept_) kept.push_back(scan.points[in_range_[k]]);
  scan.points = std::move(kept);
}

}  // namespace fuse::service

// The scans fuse-update holds while it cannot process them: fuse-state is restarting (it answers
// "recovering") or absent, so no history slice can be had. They are processed in order once it
// answers again, so a restart of fuse-state costs latency, not poses (docs/architecture.md,
// "Restarts: nothing that can be kept is lost").
//
// Bounded by the span of scan time held (update.max_backlog_s): beyond it the oldest scan is
// dropped and counted, never silently. Scans that wait behind others are compacted to the points
// the LiDAR step would keep anyway (range filter and voxel grid at the configured size, the
// updater's own first step), so 30 s of a 20k-point sensor take ~1/6 of their raw memory.
// Not thread-safe: the service guards it with its mutex.
#pragma once

#include <cstddef>
#include <deque>

#include "fuse/association/voxel_filter.hpp"
#include "fuse/core/types.hpp"
#include "fuse/estimation/estimator_config.hpp"

namespace fuse::service {

class ScanBacklog {
 public:
  ScanBacklog(const PreprocessConfig& preprocess, double max_span_s) : preprocess_(preprocess), max_span_s_(max_span_s) {}

  /// Appends a scan; returns how many of the oldest scans were dropped to respect the bound.
  std::size_t push(LidarScan scan);
  bool empty() const { return scans_.empty(); }
  std::size_t size() const { return scans_.size(); }
  LidarScan& front() { return scans_.front().scan; }
  void pop_front() { scans_.pop_front(); }
  /// Takes the oldest scan out (to process it without holding the owner's lock).
  LidarScan take_front();
  /// Puts a scan taken out back in front (it could not be processed yet); not bounded.
  void return_front(LidarScan scan);
  /// Scan time from the oldest scan's start to the newest scan's end (0 when empty).
  double span_s() const;
  /// Compacts every scan but the first `keep_raw` (those go next, as they are). Returns how many
  /// scans it compacted now.
  std::size_t compact_waiting(std::size_t keep_raw);
  std::size_t points() const;

 private:
  struct Held {
    LidarScan scan;
    bool compacted = false;
  };
  void compact(LidarScan& scan);

  PreprocessConfig preprocess_;
  double max_span_s_;
  std::deque<Held> scans_;
  VoxelFilter filter_;
  std::vector<Eigen::Vector3f> xyz_;
  std::vector<std::uint32_t> in_range_, kept_;
};

}  // namespace fuse::service

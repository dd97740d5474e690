#include "fuse/estimation/estimator.hpp"

#include <cmath>

#include "fuse/core/logging.hpp"

namespace fuse {

Estimator::Estimator(const EstimatorConfig& config)
    : config_(config), tracker_(config), updater_(config), counters_(logger("estimator")) {}

std::map<std::string, std::uint64_t> Estimator::counters() const {
  std::map<std::string, std::uint64_t> all = tracker_.counters().map();
  for (const auto* c : {&updater_.counters(), &counters_}) {
    for (const auto& [k, v] : c->map()) all[k] += v;
  }
  return all;
}

bool accept_scan(const LidarScan& scan, double last_scan_t, const StateHistory& history, double max_imu_gap,
                 Counters& counters) {
  if (!std::isfinite(scan.t_start) || !std::isfinite(scan.t_end) || scan.t_end < scan.t_start) {
    counters.count("scan_bad_time", "scan with invalid start/end time refused");
    return false;
  }
  if (!history.initialised()) {
    counters.count("scan_before_init", "scan before static initialisation finished, skipped");
    return false;
  }
  if (scan.t_end <= last_scan_t) {
    counters.count("scan_out_of_order", "scan ending at t=" + std::to_string(scan.t_end) + " is not newer than the last one, refused");
    return false;
  }
  if (scan.t_end > history.newest().t + max_imu_gap) {
    counters.count("scan_ahead_of_imu", "scan ends " + std::to_string(scan.t_end - history.newest().t) +
                                            " s after the newest IMU sample: extrapolating");
  }
  return true;
}

ScanReport Estimator::ingest(const LidarScan& scan) {
  ScanReport report;
  report.t = scan.t_end;
  report.sequence = scan.sequence;
  report.points_in = scan.points.size();
  StateHistory& history = tracker_.history();
  if (!accept_scan(scan, last_scan_t_, history, config_.divergence.max_imu_gap, counters_)) return report;
  if (!history.ensure_entry(scan.t_end)) {
    counters_.count("scan_too_old", "scan older than the state history, refused");
    return report;
  }
  last_scan_t_ = scan.t_end;
  return updater_.process(scan, history);
}

}  // namespace fuse

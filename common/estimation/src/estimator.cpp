#include "fuse/estimation/estimator.hpp"

#include <algorithm>
#include <cmath>

#include "fuse/core/logging.hpp"

namespace fuse {

Estimator::Estimator(const EstimatorConfig& config)
    : config_(config),
      tracker_(config),
      updater_(config),
      monitor_(config.tracking),
      scan_gate_(config.clock),
      counters_(logger("estimator")) {}

std::map<std::string, std::uint64_t> Estimator::counters() const {
  std::map<std::string, std::uint64_t> all = tracker_.counters().map();
  for (const auto* c : {&updater_.counters(), &counters_}) {
    for (const auto& [k, v] : c->map()) all[k] += v;
  }
  return all;
}

void Estimator::forward_events() {
  for (const StateTracker::Event& e : tracker_.take_events()) {
    monitor_.on_event(e.kind, e.t);
    // A clock step: the sensor may have moved any distance meanwhile (carried while off, a long
    // outage), farther than local re-localisation reaches. On a saved map, search it at once.
    if (e.kind == TrackingEvent::kClockStep && saved_map_) jumped_ = true;
  }
}

bool accept_scan(const LidarScan& scan, TimeGate& gate, const StateHistory& history, Counters& counters) {
  if (!std::isfinite(scan.t_start) || !std::isfinite(scan.t_end) || scan.t_end < scan.t_start) {
    counters.count("scan_bad_time", "scan with invalid start/end time refused");
    return false;
  }
  if (!history.initialised()) {
    counters.count("scan_before_init", "scan before static initialisation finished, skipped");
    return false;
  }
  // The scan stream's own time check; a jump is decided at once by the IMU clock (the history's
  // newest time): both clocks stepped, or this scan's stamp is wrong.
  std::vector<TimeGate::Decision> decisions;
  gate.push(scan.t_end, decisions, history.newest().t);
  const TimeGate::Decision& d = decisions.front();  // a reference never holds a sample
  switch (d.verdict) {
    case TimeGate::Verdict::kAccept:
      return true;
    case TimeGate::Verdict::kClockStep:
      counters.count("scan_clock_step", fmt::format("scan clock step of {:+.3f} s to t={:.6f}, as the IMU clock's: "
                                                    "the scan is used",
                                                    d.step, scan.t_end));
      return true;
    case TimeGate::Verdict::kDuplicate:
      counters.count("scan_duplicate", fmt::format("scan ending at t={:.6f} repeats the last one's end: refused", scan.t_end));
      return false;
    case TimeGate::Verdict::kOutOfOrder:
      counters.count("scan_out_of_order", fmt::format("scan ending at t={:.6f} is not newer than the last one ({:.6f} s "
                                                      "behind), refused",
                                                      scan.t_end, -d.step));
      return false;
    case TimeGate::Verdict::kOutlier:
      counters.count("scan_time_outlier",
                     fmt::format("scan ending at t={:.6f} jumps {:+.3f} s away from the scan stream, and the IMU clock "
                                 "(t={:.6f}) did not (beyond estimator.clock.max_gap_s): refused",
                                 scan.t_end, d.step, history.newest().t));
      return false;
  }
  return false;
}

ScanReport Estimator::ingest(const LidarScan& scan) {
  ScanReport report;
  report.t = scan.t_end;
  report.sequence = scan.sequence;
  report.points_in = scan.points.size();
  StateHistory& history = tracker_.history();
  // A scan whose clock made the jump that the IMU samples held by the tracker's time check made
  // confirms it at once (both clocks stepped): the scan is then judged against the new time.
  if (std::isfinite(scan.t_end) && tracker_.confirm_jump(scan.t_end)) forward_events();
  if (!accept_scan(scan, scan_gate_, history, counters_)) {
    if (history.initialised()) monitor_.on_refused_scan();
    return report;
  }
  if (scan.t_end > tracker_.last_imu_time() + config_.divergence.max_imu_gap && scan.t_end > history.newest().t) {
    // The IMU is silent at the scan end: coast to it as across a data gap, so that the scan's
    // prior is uncertain and it is re-localised (an IMU-only dropout while the LiDAR runs).
    const bool coast = config_.divergence.coast_silent_imu;
    counters_.count("scan_ahead_of_imu", fmt::format("scan ends {:.3f} s after the newest IMU sample: {}",
                                                     scan.t_end - tracker_.last_imu_time(),
                                                     coast ? "coasting the state to its end as across a data gap"
                                                           : "extrapolating (divergence.coast_silent_imu off)"));
    if (coast) tracker_.coast_to(scan.t_end);
    forward_events();
  }
  if (!history.ensure_entry(scan.t_end)) {
    counters_.count("scan_too_old", "scan older than the state history, refused");
    monitor_.on_refused_scan();
    return report;
  }
  // A lost track keeps trying: the next scan is re-localised from a widened prior (not while a
  // search of the map runs: the session then tracks its own frame).
  if (monitor_.wants_relocalisation() && localized()) tracker_.widen(scan.t_end);
  report = updater_.process(scan, history);
  monitor_.on_scan(report);
  if (localization_ && !localized()) {
    localize_step(report);
  } else {
    search_when_lost(scan.t_end);
  }
  jumped_ = false;
  return report;
}

void Estimator::localize_in(std::vector<Eigen::Vector3f> points, const std::optional<InitialPose>& initial_pose,
                            const std::optional<Eigen::Vector3d>& map_gravity) {
  map_gravity_ = map_gravity;
  saved_map_ = true;
  localization_ = std::make_unique<SessionLocalization>(config_, std::move(points), initial_pose, map_gravity, config_.map.mode);
  StateHistory& history = tracker_.history();
  localization_->start(updater_, history, history.initialised() ? history.newest_time() : 0.0);
}

void Estimator::search_when_lost(double t) {
  const GlobalLocalizationConfig& c = config_.global_localization;
  const double lost = lost_for(monitor_);
  const bool lost_long = c.lost_search_after_s > 0.0 && lost >= c.lost_search_after_s;
  if (!c.enabled || unsearchable_ || (!lost_long && !jumped_)) return;
  std::vector<Eigen::Vector3f> points = points_of(updater_.map());
  if (points.empty()) return;
  try {
    localization_ = std::make_unique<SessionLocalization>(config_, std::move(points), std::nullopt, map_gravity_,
                                                          config_.map.mode);
  } catch (const std::invalid_argument& e) {
    counters_.count("lost_search_impossible", std::string("lost, and the map cannot be searched: ") + e.what());
    unsearchable_ = true;  // the map does not change its size or gravity: not again on every scan
    return;
  }
  localization_->start(updater_, tracker_.history(), t);
  counters_.count("lost_search", lost_long ? fmt::format("lost for {:.1f} s at t={:.3f}: searching the whole map for the "
                                                         "sensor's place",
                                                         lost, t)
                                           : fmt::format("clock step before t={:.3f}: the sensor may have moved anywhere; "
                                                         "searching the whole saved map for its place",
                                                         t));
}

void Estimator::localize_step(const ScanReport& report) {
  const LocalizationEvent e = localization_->step(report, tracker_.history(), updater_);
  if (e.kind == LocalizationEvent::Kind::kConfirmed) counters_.count("global_localized", e.message);
  if (e.kind == LocalizationEvent::Kind::kDropped) counters_.count("global_localization_dropped", "global localization dropped: " + e.message);
}

}  // namespace fuse

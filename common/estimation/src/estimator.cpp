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
  for (const StateTracker::Event& e : tracker_.take_events()) monitor_.on_event(e.kind, e.t);
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
  // A lost track keeps trying: the next scan is re-localised from a widened prior.
  if (monitor_.wants_relocalisation()) tracker_.widen(scan.t_end);
  report = updater_.process(scan, history);
  monitor_.on_scan(report);
  if (localization_ && !localized()) localize_step(report);
  return report;
}

void Estimator::localize_in(std::vector<Eigen::Vector3f> points, const std::optional<InitialPose>& initial_pose,
                            const std::optional<Eigen::Vector3d>& map_gravity) {
  if (map_gravity) {
    // The search turns about z: the map must be used in the gravity-aligned frame it was built in.
    const double tilt = std::acos(std::clamp(-map_gravity->normalized().z(), -1.0, 1.0));
    if (tilt > config_.global_localization.max_map_tilt) {
      throw std::invalid_argument(fmt::format("the map's gravity is {:.2f} deg off its -z axis, more than "
                                              "global_localization.max_map_tilt ({:.2f} deg)",
                                              tilt * 180.0 / M_PI, config_.global_localization.max_map_tilt * 180.0 / M_PI));
    }
    logger("estimator")->info("the map's recorded gravity is {:.3f} deg off its -z axis", tilt * 180.0 / M_PI);
  }
  localization_ = std::make_unique<MapLocalization>(config_.global_localization, std::move(points), initial_pose,
                                                    map_gravity ? *map_gravity : -Eigen::Vector3d::UnitZ());
  T_map_session_.setIdentity();
  // The session maps its own surroundings in its own frame until it knows where it is.
  updater_.restart_map({}, "mapping");
}

void Estimator::localize_step(const ScanReport& report) {
  MapLocalization& L = *localization_;
  StateHistory& history = tracker_.history();
  const double t = report.t;
  if (L.state() == MapLocalization::State::kConfirming) {
    // The location holds if the scans after it fit the saved map (tracking.min_fit), 4 of 5 at least.
    ++confirm_scans_;
    if (!report.updated || report.match_fit < config_.tracking.min_fit) ++confirm_poor_;
    if (t < L.confirm_until()) return;
    if (5 * confirm_poor_ <= confirm_scans_) {
      L.confirmed(t);
      updater_.set_map_mode(config_.map.mode);
      counters_.count("global_localized", fmt::format("located in the saved map at t={:.3f}", t));
      return;
    }
    const std::string why = fmt::format("{} of {} scans after it did not fit the map", confirm_poor_, confirm_scans_);
    counters_.count("global_localization_dropped", "global localization dropped: " + why);
    history.transform_world(T_map_session_.inverse());
    T_map_session_.setIdentity();
    updater_.restart_map(L.session_points(), "mapping");
    L.dropped(t, why);
    return;
  }
  const std::optional<Eigen::Isometry3d> T =
      L.on_scan(t, updater_.last_world_points(), updater_.last_T_world_lidar().translation(), history.query(t).x.g);
  if (!T) return;
  // Into the map's frame: the history by T_M_S, the saved map for the session's (not extended
  // while the location is being confirmed), and a prior as wide as the search's step (a cell in
  // position, about a degree of heading) so that the next scan is re-localised against the map.
  history.transform_world(*T);
  T_map_session_ = *T;
  updater_.restart_map(L.map_points(), "localization");
  const double r = L.resolution();
  StateVector q = StateVector::Zero();
  q.segment<3>(Idx::kPos).setConstant(r * r);
  q.segment<3>(Idx::kRot).setConstant(0.03 * 0.03);
  history.inflate(t, q);
  L.taken(t);
  confirm_scans_ = confirm_poor_ = 0;
}

}  // namespace fuse

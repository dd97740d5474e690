#include "fuse/estimation/session_localization.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "fuse/core/logging.hpp"

namespace fuse {

namespace {
MapLocalization make_search(const GlobalLocalizationConfig& config, std::vector<Eigen::Vector3f> points,
                            const std::optional<InitialPose>& initial_pose, const std::optional<Eigen::Vector3d>& map_gravity) {
  if (map_gravity) {
    // The search turns about z: the map must be used in the gravity-aligned frame it was built in.
    const double tilt = std::acos(std::clamp(-map_gravity->normalized().z(), -1.0, 1.0));
    if (tilt > config.max_map_tilt) {
      throw std::invalid_argument(fmt::format("the map's gravity is {:.2f} deg off its -z axis, more than "
                                              "global_localization.max_map_tilt ({:.2f} deg)",
                                              tilt * 180.0 / M_PI, config.max_map_tilt * 180.0 / M_PI));
    }
    logger("estimator")->info("the map's recorded gravity is {:.3f} deg off its -z axis", tilt * 180.0 / M_PI);
  }
  return MapLocalization(config, std::move(points), initial_pose, map_gravity ? *map_gravity : -Eigen::Vector3d::UnitZ());
}

}  // namespace

SessionLocalization::SessionLocalization(const EstimatorConfig& config, std::vector<Eigen::Vector3f> map_points,
                                         const std::optional<InitialPose>& initial_pose,
                                         const std::optional<Eigen::Vector3d>& map_gravity, std::string map_mode)
    : config_(config),
      search_(make_search(config.global_localization, std::move(map_points), initial_pose, map_gravity)),
      map_mode_(std::move(map_mode)) {}

void SessionLocalization::start(LidarUpdater& updater, StateHistory& history, double t) {
  updater.restart_map({}, "mapping");
  if (!history.initialised() || !history.ensure_entry(t)) return;
  const StateQuery q = history.query(t);
  if (!q.ok()) return;
  // The pose in its own frame: position and rotation σ of an initialised state (1 cm, 0.01 rad),
  // uncorrelated with the rest; the velocity, biases and gravity keep what they had.
  constexpr double kAnchorPositionVar = 1e-4, kAnchorRotationVar = 1e-4;
  StateCovariance P = q.P;
  for (const int block : {Idx::kPos, Idx::kRot}) {
    P.middleRows<3>(block).setZero();
    P.middleCols<3>(block).setZero();
    P.block<3, 3>(block, block) =
        Eigen::Matrix3d::Identity() * (block == Idx::kPos ? kAnchorPositionVar : kAnchorRotationVar);
  }
  history.correct(t, q.x, P);
}

LocalizationEvent SessionLocalization::step(const ScanReport& report, StateHistory& history, LidarUpdater& updater) {
  LocalizationEvent e;
  const double t = report.t;
  switch (search_.state()) {
    case MapLocalization::State::kLocalized:
      return e;
    case MapLocalization::State::kConfirming: {
      // The location holds if the scans after it fit the saved map (tracking.min_fit), 4 of 5 at least.
      ++confirm_scans_;
      if (!report.updated || report.match_fit < config_.tracking.min_fit) ++confirm_poor_;
      if (t < search_.confirm_until()) return e;
      if (5 * confirm_poor_ <= confirm_scans_) {
        search_.confirmed(t);
        updater.set_map_mode(map_mode_);
        e.kind = LocalizationEvent::Kind::kConfirmed;
        e.message = fmt::format("located in the saved map at t={:.3f}", t);
        return e;
      }
      e.kind = LocalizationEvent::Kind::kDropped;
      e.message = fmt::format("{} of {} scans after it did not fit the map", confirm_poor_, confirm_scans_);
      e.T_new_old = T_map_session_.inverse();
      history.transform_world(e.T_new_old);
      T_map_session_.setIdentity();
      updater.restart_map(search_.session_points(), "mapping");
      search_.dropped(t, e.message);
      return e;
    }
    case MapLocalization::State::kSearching:
      break;
  }
  const std::optional<Eigen::Isometry3d> T =
      search_.on_scan(t, updater.last_world_points(), updater.last_T_world_lidar().translation(), history.query(t).x.g);
  if (!T) return e;
  // Into the map's frame: the history by T_M_S, the saved map for the session's (not extended
  // while the location is being confirmed), and a prior as wide as the search's step (a cell in
  // position, about a degree of heading) so that the next scan is re-localised against the map.
  history.transform_world(*T);
  T_map_session_ = *T;
  updater.restart_map(search_.map_points(), "localization");
  const double r = search_.resolution();
  StateVector q = StateVector::Zero();
  q.segment<3>(Idx::kPos).setConstant(r * r);
  q.segment<3>(Idx::kRot).setConstant(0.03 * 0.03);
  history.inflate(t, q);
  search_.taken(t);
  confirm_scans_ = confirm_poor_ = 0;
  e.kind = LocalizationEvent::Kind::kTaken;
  e.T_new_old = *T;
  e.message = fmt::format("location taken at t={:.3f}; confirming it over {:.1f} s of scans", t,
                          config_.global_localization.confirm_s);
  return e;
}

double lost_for(const TrackingMonitor& monitor) {
  if (monitor.status() != TrackingStatus::kLost || monitor.episodes().empty()) return 0.0;
  const TrackingMonitor::Episode& e = monitor.episodes().back();
  return e.status == TrackingStatus::kLost ? e.duration : 0.0;
}

std::vector<Eigen::Vector3f> points_of(const SpatialIndex& map) {
  std::vector<Eigen::Vector3f> points;
  points.reserve(map.size());
  map.for_each_point([&](const Eigen::Vector3f& p) { points.push_back(p); });
  return points;
}

InitialPose at_session_start(const InitialPose& now, const Eigen::Isometry3d& T_S_imu) {
  InitialPose s = now;
  s.yaw = now.yaw - heading(T_S_imu.linear());
  s.position = now.position - Eigen::AngleAxisd(s.yaw, Eigen::Vector3d::UnitZ()) * T_S_imu.translation();
  return s;
}

}  // namespace fuse

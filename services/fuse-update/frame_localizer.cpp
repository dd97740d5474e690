#include "frame_localizer.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "fuse/core/logging.hpp"

namespace fuse::service {

namespace {
constexpr const char* kLog = "fuse-update";
/// A located pose farther than this from the one given is reported as a correction of it.
constexpr double kCorrectedOffset = 0.5;               // m
constexpr double kCorrectedTurn = 5.0 * M_PI / 180.0;  // rad
/// Epochs whose change is kept for slices of a fuse-state that lags behind.
constexpr std::size_t kKeptEpochs = 64;
constexpr std::size_t kKeptVerdicts = 16;
/// s of scan poses kept for set-pose requests about the recent past.
constexpr double kTrackS = 60.0;

double wrap(double a) { return std::atan2(std::sin(a), std::cos(a)); }
}  // namespace

bool FrameLocalizer::reconcile(const WorldFrame& slice, StateHistory& history, LidarUpdater& updater, const MapContext& map) {
  map_ = map;
  bool known = synced_ && slice.state != fuse_msgs::MAP_FRAME_UNDECIDED && slice.epoch <= frame_.epoch;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (std::uint32_t e = slice.epoch + 1; known && e <= frame_.epoch; ++e) {
    const auto it = sent_.find(e);
    if (it == sent_.end()) known = false;
    else T = it->second * T;
  }
  if (known) {
    // fuse-state has not applied the newest changes yet (or this one has not sent them).
    T = unsent_ * T;
    if (!T.isApprox(Eigen::Isometry3d::Identity())) history.transform_world(T);
    return false;
  }
  // A frame this instance does not know: fuse-state's is the truth (a restart on either side).
  if (synced_) {
    logger(kLog)->info("world frame: following fuse-state's ({}, epoch {}) instead of ours ({}, epoch {})",
                       to_string(slice.state), slice.epoch, to_string(frame_.state), frame_.epoch);
  }
  synced_ = true;
  frame_ = slice;
  dirty_ = false;
  unsent_.setIdentity();
  sent_.clear();
  track_.clear();
  const double t = history.newest().t;
  switch (slice.state) {
    case fuse_msgs::MAP_FRAME_UNDECIDED:
      // The first scan of a new state: search a saved map for the session's place, or make the
      // session's frame the map's.
      if ((config_.global_localization.enabled || request_) && has_saved_map(updater)) {
        begin_search(history, updater, t);
      } else {
        if (localization_) end_search(updater, fuse_msgs::MAP_FRAME_OWN);
        set_state(fuse_msgs::MAP_FRAME_OWN);
        logger(kLog)->info("world frame: the session's own frame is the map's ({})",
                           has_saved_map(updater) ? "global localization is off" : "no saved map");
      }
      break;
    case fuse_msgs::MAP_FRAME_SEARCHING:
    case fuse_msgs::MAP_FRAME_CONFIRMING:
      begin_search(history, updater, t);  // from the frame the history is in now
      break;
    case fuse_msgs::MAP_FRAME_OWN:
    case fuse_msgs::MAP_FRAME_LOCALIZED:
      if (localization_) end_search(updater, slice.state);
      break;
  }
  return true;
}

LocalizationEvent FrameLocalizer::step(const ScanReport& report, StateHistory& history, LidarUpdater& updater,
                                       double lost_s) {
  track_.emplace_back(report.t, history.query(report.t).x.T_WI());
  while (!track_.empty() && track_.front().first < report.t - kTrackS) track_.pop_front();
  if (request_ && synced_) {  // a set-pose request: from the next scan, a search around it
    begin_search(history, updater, report.t);
    return {};
  }
  if (!localization_) {
    const GlobalLocalizationConfig& c = config_.global_localization;
    if (!synced_ || unsearchable_ || !c.enabled || c.lost_search_after_s <= 0.0 || lost_s < c.lost_search_after_s) return {};
    // Lost and found: the track stopped fitting the map and local re-localisation keeps failing.
    begin_search(history, updater, report.t);
    LocalizationEvent e;
    if (localization_) {
      e.kind = LocalizationEvent::Kind::kSearchStarted;
      e.message = fmt::format("lost for {:.1f} s at t={:.3f} (local re-localisation failing): searching the whole map "
                              "for the sensor's place",
                              lost_s, report.t);
    }
    return e;
  }
  const bool refused_before = localization_->search().initial_pose_refused();
  LocalizationEvent e = localization_->step(report, history, updater);
  switch (e.kind) {
    case LocalizationEvent::Kind::kTaken:
      change(e.T_new_old);
      set_state(fuse_msgs::MAP_FRAME_CONFIRMING);
      break;
    case LocalizationEvent::Kind::kDropped:
      change(e.T_new_old);
      set_state(fuse_msgs::MAP_FRAME_SEARCHING);
      break;
    case LocalizationEvent::Kind::kConfirmed:
      set_state(fuse_msgs::MAP_FRAME_LOCALIZED);
      break;
    case LocalizationEvent::Kind::kNone:
    case LocalizationEvent::Kind::kSearchStarted:
      break;
  }
  if (check_) judge_pose(e, refused_before, history, updater, report.t);
  if (localization_ && localization_->localized()) localization_.reset();  // the search's grids go
  return e;
}

void FrameLocalizer::judge_pose(const LocalizationEvent& e, bool refused_before, StateHistory& history,
                                LidarUpdater& updater, double t) {
  PoseVerdict& v = verdicts_[check_->id];
  const bool refused_now = !refused_before && localization_->search().initial_pose_refused();
  if (refused_now || e.kind == LocalizationEvent::Kind::kDropped) {
    v.result = fuse_msgs::SET_POSE_REFUSED;
    const auto& last = localization_->search().last_result();
    if (refused_now) {
      v.detail = fmt::format("nothing within 3 sigma of the pose fits the map: best fit {:.2f} (needs {:.2f}, within the "
                             "window's inner {:.0f}%)",
                             last ? last->best.fit : 0.0, config_.global_localization.min_fit,
                             100.0 * config_.global_localization.window_inner);
    } else {
      v.detail = "the location near the pose did not hold: " + e.message;
    }
    const fuse_msgs::MapFrame resume = check_->resume;
    check_.reset();
    if (resume != fuse_msgs::MAP_FRAME_SEARCHING) {
      end_search(updater, resume);  // back to tracking where it was
    } else {
      logger(kLog)->info("set-pose refused: searching the whole map");
    }
    return;
  }
  if (e.kind != LocalizationEvent::Kind::kConfirmed) return;
  const Eigen::Isometry3d& T_found = localization_->T_map_session();
  const Eigen::Vector3d given = check_->T_M_S_given * check_->sensor_S, found = T_found * check_->sensor_S;
  v.offset = (found - given).head<2>().norm();
  v.turn = wrap(heading(T_found.linear()) - heading(check_->T_M_S_given.linear()));
  const NavState x = history.query(t).x;
  v.position = x.p;
  v.yaw = heading(x.R);
  const bool corrected = v.offset > kCorrectedOffset || std::abs(v.turn) > kCorrectedTurn;
  v.result = corrected ? fuse_msgs::SET_POSE_CORRECTED : fuse_msgs::SET_POSE_ACCEPTED;
  v.detail = fmt::format("confirmed {:.2f} m and {:.1f} deg from the pose given", v.offset, v.turn * 180.0 / M_PI);
  check_.reset();
}

void FrameLocalizer::begin_search(StateHistory& history, LidarUpdater& updater, double t) {
  std::vector<Eigen::Vector3f> points = saved_map(updater);
  std::optional<InitialPose> initial;
  std::optional<PoseCheck> check;
  if (request_) {
    // Where the IMU was, in the current frame, when the pose holds: the scan end nearest to it.
    Eigen::Isometry3d T_S_imu = history.query(t).x.T_WI();
    if (request_->t > 0.0 && !track_.empty()) {
      const auto nearest = std::min_element(track_.begin(), track_.end(), [&](const auto& a, const auto& b) {
        return std::abs(a.first - request_->t) < std::abs(b.first - request_->t);
      });
      constexpr double kMaxStampGap = 0.5;  // s: beyond this the pose's time is not in the track
      if (std::abs(nearest->first - request_->t) > kMaxStampGap) {
        verdicts_[request_->id] = PoseVerdict{
            fuse_msgs::SET_POSE_REFUSED, {}, 0, 0, 0,
            fmt::format("the pose's time t={:.3f} is not within the last {:.0f} s of scans [{:.3f}, {:.3f}]", request_->t,
                        kTrackS, track_.front().first, track_.back().first)};
        request_.reset();
        return;
      }
      T_S_imu = nearest->second;
    }
    initial = at_session_start(request_->pose, T_S_imu);
    PoseCheck c;
    c.id = request_->id;
    c.T_M_S_given = Eigen::Isometry3d::Identity();
    c.T_M_S_given.linear() = Eigen::AngleAxisd(initial->yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    c.T_M_S_given.translation() = initial->position;
    c.sensor_S = T_S_imu.translation();
    // Refused: back to where it was (a search goes on searching the whole map).
    c.resume = frame_.state == fuse_msgs::MAP_FRAME_OWN || frame_.state == fuse_msgs::MAP_FRAME_LOCALIZED
                   ? frame_.state
                   : fuse_msgs::MAP_FRAME_SEARCHING;
    check = c;
    request_.reset();
  }
  if (points.empty()) {
    if (check) {
      verdicts_[check->id] = PoseVerdict{fuse_msgs::SET_POSE_REFUSED, {}, 0, 0, 0, "the map is empty: nothing to localize in"};
    }
    return;
  }
  std::unique_ptr<SessionLocalization> next;
  try {
    next = std::make_unique<SessionLocalization>(config_, std::move(points), initial, map_.gravity, map_.mode);
  } catch (const std::exception& e) {
    logger(kLog)->error("global localization cannot search this map: {}", e.what());
    unsearchable_ = true;  // not again on every lost scan: a new map clears it
    problem_ = std::string("the saved map cannot be searched: ") + e.what() +
               (localization_ ? "" : "; the session's frame is taken as the map's");
    if (check) verdicts_[check->id] = PoseVerdict{fuse_msgs::SET_POSE_REFUSED, {}, 0, 0, 0, e.what()};
    if (!localization_) set_state(frame_.state == fuse_msgs::MAP_FRAME_UNDECIDED ? fuse_msgs::MAP_FRAME_OWN : frame_.state);
    return;
  }
  if (localization_ && frame_.state == fuse_msgs::MAP_FRAME_CONFIRMING) {
    logger(kLog)->info("the location being confirmed is set aside: a new search starts from here");
  }
  localization_ = std::move(next);
  localization_->start(updater, history, t);
  check_ = check;
  set_state(fuse_msgs::MAP_FRAME_SEARCHING);
  logger(kLog)->info("world frame: searching the saved map{}", check_ ? " around the pose given" : "");
}

void FrameLocalizer::end_search(LidarUpdater& updater, fuse_msgs::MapFrame state) {
  updater.restart_map(localization_->search().map_points(), map_.mode == "localization" ? "localization" : "mapping");
  localization_.reset();
  set_state(state);
}

void FrameLocalizer::map_replaced(LidarUpdater& updater, const MapContext& map, double t) {
  map_ = map;
  unsearchable_ = false;
  if (!localization_) return;
  if (frame_.state == fuse_msgs::MAP_FRAME_CONFIRMING) change(localization_->T_map_session().inverse());
  localization_.reset();
  (void)t;
  std::vector<Eigen::Vector3f> points = saved_map(updater);
  if (points.empty()) {
    set_state(fuse_msgs::MAP_FRAME_OWN);
    return;
  }
  try {
    localization_ = std::make_unique<SessionLocalization>(config_, std::move(points), std::nullopt, map_.gravity, map_.mode);
    updater.restart_map({}, "mapping");  // the session maps its own surroundings again
    set_state(fuse_msgs::MAP_FRAME_SEARCHING);
    logger(kLog)->info("the map server replaced its map: the search starts again on the new one");
  } catch (const std::exception& e) {
    logger(kLog)->error("global localization cannot search the new map: {}; its origin is taken as the session's", e.what());
    set_state(fuse_msgs::MAP_FRAME_OWN);
  }
}

void FrameLocalizer::fill(fuse_msgs::Correction& c) {
  if (dirty_) {
    ++frame_.epoch;
    sent_[frame_.epoch] = unsent_;
    while (sent_.size() > kKeptEpochs) sent_.erase(sent_.begin());
    unsent_.setIdentity();
    dirty_ = false;
  }
  const auto it = sent_.find(frame_.epoch);
  const Eigen::Isometry3d T = it != sent_.end() ? it->second : Eigen::Isometry3d::Identity();
  c.map_frame(frame_.state);
  c.frame_epoch(frame_.epoch);
  c.frame_change(to_pose(T.translation(), T.linear()));
  c.localization_candidates(static_cast<std::uint32_t>(candidates()));
  c.localization(describe().substr(0, 127));
}

void FrameLocalizer::request_pose(std::uint64_t id, const InitialPose& pose, double t) {
  request_ = PoseRequest{id, pose, t};
  verdicts_[id] = PoseVerdict{};
  while (verdicts_.size() > kKeptVerdicts) verdicts_.erase(verdicts_.begin());
}

PoseVerdict FrameLocalizer::verdict(std::uint64_t id) const {
  const auto it = verdicts_.find(id);
  return it != verdicts_.end() ? it->second : PoseVerdict{};
}

std::string FrameLocalizer::describe() const {
  return localization_ ? localization_->search().describe() : std::string(to_string(frame_.state));
}

bool FrameLocalizer::has_saved_map(const LidarUpdater& updater) const {
  return localization_ ? !localization_->search().map_points().empty() : updater.map().size() > 0;
}

std::vector<Eigen::Vector3f> FrameLocalizer::saved_map(const LidarUpdater& updater) const {
  return localization_ ? localization_->search().map_points() : points_of(updater.map());
}

}  // namespace fuse::service

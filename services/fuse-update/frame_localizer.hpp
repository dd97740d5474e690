// fuse-update's side of the world frame against a saved map (docs/architecture.md, "Starting
// anywhere in a saved map"). fuse-state's history owns the frame (WorldFrame: state and epoch);
// this instance decides it and changes it:
//   - at the first scan of a new state (undecided): a non-empty saved map and
//     estimator.global_localization.enabled (or a set-pose request) start a search in the
//     session's own frame (SessionLocalization); otherwise the session's frame is the map's (own);
//   - a search's location taken, dropped or confirmed, a set-pose request, a map replaced while
//     searching: each change is made on this instance's history slice at once and sent with the
//     next correction (a new epoch, frame_change = every change since the last one sent);
//   - a slice from fuse-state one or more epochs behind (it has not applied the last corrections
//     yet) is brought into this instance's frame by the changes it lacks; a slice of a frame this
//     instance does not know (fuse-state or this service restarted) is adopted as it is.
// Nothing is offered to the map while the frame is not the map's (writes_map()).
#pragma once

#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "fuse/estimation/session_localization.hpp"
#include "fuse/service/convert.hpp"

namespace fuse::service {

/// The verdict on a set-pose request (fuse_msgs::SetPoseResult).
struct PoseVerdict {
  fuse_msgs::SetPoseResult result = fuse_msgs::SET_POSE_PENDING;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< the IMU where it was located (map frame)
  double yaw = 0.0;
  double offset = 0.0;  ///< m, horizontal, from the pose given
  double turn = 0.0;    ///< rad, from the pose given
  std::string detail;
};

class FrameLocalizer {
 public:
  /// What the saved map is, for a decision or a new search.
  struct MapContext {
    std::string mode;                          ///< the map server's mode, once located
    std::optional<Eigen::Vector3d> gravity;    ///< the map frame's gravity, when the map recorded it
  };

  /// The search always runs on its own thread here (global_localization.blocking is for offline
  /// runs): scans and queries go on while it does.
  explicit FrameLocalizer(const EstimatorConfig& config) : config_(config) { config_.global_localization.blocking = false; }

  /// Brings a history slice (frame `slice`) into this instance's frame, adopting fuse-state's when
  /// it is one this instance does not know (returns true then: older posteriors no longer apply).
  bool reconcile(const WorldFrame& slice, StateHistory& history, LidarUpdater& updater, const MapContext& map);
  /// After a scan's LiDAR step: the search's step; its event (logged and counted by the caller).
  /// `lost_s`: how long the track has been lost with local re-localisation failing (lost_for):
  /// past global_localization.lost_search_after_s the whole map is searched again.
  LocalizationEvent step(const ScanReport& report, StateHistory& history, LidarUpdater& updater, double lost_s);
  /// The map server replaced the saved map (updater rebuilt on it): a search starts again on it.
  void map_replaced(LidarUpdater& updater, const MapContext& map, double t);
  /// Fills a correction's frame fields, opening a new epoch when the frame changed since the last.
  void fill(fuse_msgs::Correction& c);

  /// A set-pose request: the IMU's pose at sensor time t (0: now), taken at the next scan (`id`
  /// names its verdict).
  void request_pose(std::uint64_t id, const InitialPose& pose, double t);
  /// The verdict on request `id` (pending while checked).
  PoseVerdict verdict(std::uint64_t id) const;

  const WorldFrame& frame() const { return frame_; }
  bool writes_map() const {
    return frame_.state == fuse_msgs::MAP_FRAME_OWN || frame_.state == fuse_msgs::MAP_FRAME_LOCALIZED;
  }
  std::string describe() const;
  /// A problem found since the last call (a saved map that cannot be searched), for health; empty if none.
  std::string take_problem() { return std::exchange(problem_, std::string()); }
  std::size_t candidates() const { return localization_ ? localization_->candidates() : 0; }

 private:
  struct PoseRequest {
    std::uint64_t id = 0;
    InitialPose pose;
    double t = 0.0;  ///< 0: now
  };
  struct PoseCheck {
    std::uint64_t id = 0;
    Eigen::Isometry3d T_M_S_given;  ///< the session frame in the map as the request put it
    Eigen::Vector3d sensor_S;       ///< the IMU in the session frame at the request
    fuse_msgs::MapFrame resume = fuse_msgs::MAP_FRAME_SEARCHING;  ///< the state to go back to when refused
  };
  void set_state(fuse_msgs::MapFrame state) {
    if (state != frame_.state) dirty_ = true;
    frame_.state = state;
  }
  void change(const Eigen::Isometry3d& T_new_old) {
    unsent_ = T_new_old * unsent_;
    dirty_ = true;
    for (auto& [t, pose] : track_) pose = T_new_old * pose;
  }
  /// Starts a search in the current frame (around a requested pose when one waits).
  void begin_search(StateHistory& history, LidarUpdater& updater, double t);
  /// Ends the search: the updater tracks the saved map again in `state`.
  void end_search(LidarUpdater& updater, fuse_msgs::MapFrame state);
  void judge_pose(const LocalizationEvent& e, bool refused_before, StateHistory& history, LidarUpdater& updater, double t);
  /// The saved map's points (set aside by a search, or the updater's replica), and whether it has any.
  std::vector<Eigen::Vector3f> saved_map(const LidarUpdater& updater) const;
  bool has_saved_map(const LidarUpdater& updater) const;

  EstimatorConfig config_;
  WorldFrame frame_;
  bool synced_ = false;  ///< frame_ follows fuse-state's (set at the first slice)
  bool dirty_ = false;   ///< frame_ changed since the last correction filled
  bool unsearchable_ = false;  ///< the saved map cannot be searched (refused by the search): no lost search
  std::string problem_;        ///< for take_problem()
  Eigen::Isometry3d unsent_ = Eigen::Isometry3d::Identity();   ///< the change not sent yet
  std::map<std::uint32_t, Eigen::Isometry3d> sent_;             ///< change that opened each recent epoch
  std::unique_ptr<SessionLocalization> localization_;
  MapContext map_;
  std::optional<PoseRequest> request_;
  std::optional<PoseCheck> check_;
  std::map<std::uint64_t, PoseVerdict> verdicts_;  ///< recent ones
  /// T_world_imu at the recent scan ends, in the current frame (moved with each change): where the
  /// IMU was when a set-pose request's pose holds.
  std::deque<std::pair<double, Eigen::Isometry3d>> track_;
};

}  // namespace fuse::service

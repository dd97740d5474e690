// Starting anywhere in a saved map: the session runs LiDAR-inertial odometry in its own frame S
// (static initialisation: z up, heading 0, origin at the start), gathers what it sees into a
// submap, and searches the saved map M for it (GlobalLocalizer) until a search gives one
// unambiguous location: T_M_S = [Rz(ψ) | t − Rz(ψ) p_S], with (t, ψ) the sensor's pose found in M
// and p_S its position in S when the submap was taken. The owner (Estimator) then moves its
// history into M by T_M_S, swaps the session map for the saved one and lets the next scans refine
// and confirm the location; one that does not fit is dropped and the search goes on.
//
// An initial pose (fuse-run --initial-pose, the set-pose request) restricts the search to a window
// around it (its σ); if nothing fits there, the pose is refused and the whole map is searched.
#pragma once

#include <Eigen/Geometry>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "fuse/estimation/global_localizer.hpp"

namespace fuse {

/// A pose of the IMU in the map frame at the session's start, as "2D Pose Estimate" gives it:
/// position, heading, and their σ (roll and pitch come from gravity).
struct InitialPose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double yaw = 0.0;      ///< rad
  double std_xy = 1.0;   ///< m
  double std_z = 0.5;    ///< m
  double std_yaw = 0.2;  ///< rad
};

class MapLocalization {
 public:
  enum class State { kSearching, kConfirming, kLocalized };

  /// Builds the search grids of the saved map (throws std::invalid_argument like GlobalLocalizer).
  /// `map_gravity`: the gravity direction the map recorded (default −z). The search levels both
  /// sides: the map by the rotation taking its gravity to −z, the submap by the one taking the
  /// session's current gravity estimate to −z, so that four degrees of freedom remain however the
  /// two frames' static initialisations tilted them (0.65° apart on the corridor fixture: 0.28 m
  /// at the edge of a 25 m submap).
  MapLocalization(const GlobalLocalizationConfig& config, std::vector<Eigen::Vector3f> map_points,
                  std::optional<InitialPose> initial_pose, const Eigen::Vector3d& map_gravity = -Eigen::Vector3d::UnitZ());
  ~MapLocalization();

  /// One scan processed in the session frame S: the points it placed there and the sensor's
  /// position. Starts a search when one is due; returns T_M_S when a search found one location.
  /// `gravity_S`: the session's current gravity estimate in S.
  std::optional<Eigen::Isometry3d> on_scan(double t, const std::vector<Eigen::Vector3f>& points_S, const Eigen::Vector3d& sensor_S,
                                           const Eigen::Vector3d& gravity_S = -Eigen::Vector3d::UnitZ());
  /// The location returned last was taken (kConfirming) / confirmed by the scans after it / dropped.
  void taken(double t);
  void confirmed(double t);
  void dropped(double t, const std::string& why);

  State state() const { return state_; }
  /// m: the search grid's cell (coarser than configured for a large map).
  double resolution() const { return localizer_->config().resolution; }
  const std::vector<Eigen::Vector3f>& map_points() const { return map_points_; }
  /// The session's submap, in S (what the session map is rebuilt from when a location is dropped).
  std::vector<Eigen::Vector3f> session_points() const;
  /// Searches finished, the last one's result, and how much data the session had then.
  std::size_t searches() const { return searches_; }
  /// s of wall time the finished searches took (their own thread's work).
  double search_seconds() const { return search_ms_ / 1000.0; }
  const std::optional<GlobalSearchResult>& last_result() const { return last_; }
  double confirm_until() const { return confirm_until_; }
  /// "searching (3 candidates)", "localized", ...: for health, queries and logs.
  std::string describe() const;
  /// Whether the initial pose was refused (nothing in its window fitted) and the map searched.
  bool initial_pose_refused() const { return initial_pose_refused_; }

 private:
  struct Pending {
    std::future<GlobalSearchResult> result;
    Eigen::Vector3d sensor_S;
    Eigen::Matrix3d level_S;  ///< R taking the session's gravity to −z, when the submap was taken
    bool windowed = false;
  };
  std::optional<SearchWindow> window_for(const Eigen::Vector3d& sensor_S) const;
  /// The finished search's result (a search that threw counts as one that found nothing).
  static GlobalSearchResult take(Pending& p);
  std::optional<Eigen::Isometry3d> finish(GlobalSearchResult r, const Pending& p, double t);

  GlobalLocalizationConfig config_;
  std::vector<Eigen::Vector3f> map_points_;
  Eigen::Matrix3d level_M_;  ///< R_M'M: the map levelled (its gravity to −z) for the search
  std::shared_ptr<const GlobalLocalizer> localizer_;  ///< shared with a running search
  std::optional<InitialPose> initial_pose_;
  bool initial_pose_refused_ = false;
  State state_ = State::kSearching;
  std::unordered_map<std::uint64_t, Eigen::Vector3f> submap_;  ///< one point per half cell, in S
  std::optional<Pending> pending_;
  std::optional<double> t_first_;
  std::optional<Eigen::Vector3d> last_search_at_;
  double last_search_t_ = 0.0;
  std::optional<GlobalSearchResult> last_;
  /// The location the latest searches agreed on so far (T_M_S) and how many did.
  std::optional<Eigen::Isometry3d> agreed_;
  int agreeing_ = 0;
  std::size_t searches_ = 0;
  double search_ms_ = 0.0;
  double confirm_until_ = 0.0;
};

const char* to_string(MapLocalization::State s);

/// The smallest rotation taking the direction g to −z (levelling a frame whose gravity is g).
Eigen::Matrix3d levelling(const Eigen::Vector3d& g);

}  // namespace fuse

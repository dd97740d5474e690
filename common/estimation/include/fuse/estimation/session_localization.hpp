// A session's place in a saved map, for the owner of a LiDAR step (fuse-run's Estimator, the
// fuse-update service): MapLocalization's search plus what a found location does to the session.
//
//   start       the session runs in its own frame S on a map of its own surroundings
//   step        after each scan's LiDAR step: a location the search found is taken (the history
//               moves into the map frame by T_M_S, the saved map replaces the session's, the prior
//               widens to the search's step), then confirmed when the next confirm_s of scans fit
//               the saved map (4 of 5 with tracking.min_fit), or dropped (the history moves back,
//               the session map is rebuilt from the submap) and the search goes on
//
// Each change of frame is returned as T_new_old so that a service can send it to the owner of the
// authoritative history (fuse-state); nothing is written to the saved map before confirmation.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fuse/estimation/estimator_config.hpp"
#include "fuse/estimation/lidar_updater.hpp"
#include "fuse/estimation/map_localization.hpp"
#include "fuse/estimation/scan_report.hpp"
#include "fuse/estimation/state_history.hpp"
#include "fuse/estimation/tracking_monitor.hpp"

namespace fuse {

/// What one scan did to the session's place in the saved map.
struct LocalizationEvent {
  enum class Kind { kNone, kTaken, kConfirmed, kDropped, kSearchStarted };
  Kind kind = Kind::kNone;
  Eigen::Isometry3d T_new_old = Eigen::Isometry3d::Identity();  ///< the world frame's change (kTaken, kDropped)
  std::string message;                                          ///< for logs and health
};

class SessionLocalization {
 public:
  /// Throws std::invalid_argument when the map cannot be searched (too large, or its gravity farther
  /// than global_localization.max_map_tilt from −z). `map_mode`: the mode once confirmed.
  SessionLocalization(const EstimatorConfig& config, std::vector<Eigen::Vector3f> map_points,
                      const std::optional<InitialPose>& initial_pose, const std::optional<Eigen::Vector3d>& map_gravity,
                      std::string map_mode);

  /// The session maps its own surroundings in its current frame until it knows where it is. The
  /// frame is anchored at the pose at t: its position and heading are known there (a lost track's
  /// widened prior would otherwise keep growing, the next scans having no map to fit).
  void start(LidarUpdater& updater, StateHistory& history, double t);
  /// After a scan's LiDAR step on `history` (the updater's): feeds the search, takes, confirms or
  /// drops a location.
  LocalizationEvent step(const ScanReport& report, StateHistory& history, LidarUpdater& updater);

  bool localized() const { return search_.state() == MapLocalization::State::kLocalized; }
  /// T_M_S: the session frame in the map's (identity until a location is taken).
  const Eigen::Isometry3d& T_map_session() const { return T_map_session_; }
  const MapLocalization& search() const { return search_; }
  /// The candidates of the last search (0 before one finished).
  std::size_t candidates() const { return search_.last_result() ? search_.last_result()->candidates : 0; }

 private:
  EstimatorConfig config_;
  MapLocalization search_;
  std::string map_mode_;
  Eigen::Isometry3d T_map_session_ = Eigen::Isometry3d::Identity();
  std::size_t confirm_scans_ = 0, confirm_poor_ = 0;  ///< scans since a location was taken, and those not fitting
};

/// s the track has been lost in its current episode (re-localisation failing, or a confident prior
/// fitting poorly: a wrong place taken after a jump); 0 otherwise. Lost and found: past
/// global_localization.lost_search_after_s the owner searches the whole map again, a search that
/// is verified before anything is taken (unlike a local re-localisation from a widened prior).
double lost_for(const TrackingMonitor& monitor);

/// The heading of a rotation: the angle of its x axis about z (the part a search turns).
inline double heading(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

/// The points of a spatial index (the map to search when the track is lost).
std::vector<Eigen::Vector3f> points_of(const SpatialIndex& map);

/// An initial pose given for the IMU now (at T_S_imu in the session frame S), as the pose of the
/// session frame's origin that MapLocalization searches around: heading ψ_M − ψ_S, position
/// p_M − Rz(ψ_M − ψ_S) p_S (roll and pitch come from gravity on both sides).
InitialPose at_session_start(const InitialPose& now, const Eigen::Isometry3d& T_S_imu);

}  // namespace fuse

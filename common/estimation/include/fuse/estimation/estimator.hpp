// The FUSE estimation interface (DESIGN §1): ingest, propagate, update, query over one time base,
// with the four roles plugged in by config: temporal (StateHistory), spatial (SpatialIndex +
// Associator), inference (UpdateBackend) and functional (MapPolicy).
//
// The single-process composition of the two sides the services split between them:
// StateTracker (IMU checks, initialisation, propagation: fuse-state) and LidarUpdater (one LiDAR
// step on a history: fuse-update). One scan: check it (its time too: TimeGate against the scan
// stream, a jump decided by the IMU clock), coast the history to its end t_e when the IMU is
// silent there, make sure the history has an entry at t_e, run the LiDAR step there (which
// corrects the history at t_e and re-propagates the later IMU), check for divergence, and judge
// the tracking status from the step's report (TrackingMonitor).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "fuse/estimation/estimator_config.hpp"
#include "fuse/estimation/lidar_updater.hpp"
#include "fuse/estimation/session_localization.hpp"
#include "fuse/estimation/state_tracker.hpp"
#include "fuse/estimation/tracking_monitor.hpp"

namespace fuse {

class Estimator {
 public:
  explicit Estimator(const EstimatorConfig& config);

  /// D_in: checks and routes one IMU sample (→ propagate).
  void ingest(const ImuSample& imu) {
    tracker_.ingest(imu);
    forward_events();
  }
  /// D_in: checks one scan and runs the LiDAR step; returns its report. Throws DivergenceError.
  ScanReport ingest(const LidarScan& scan);
  /// Φ_k: propagation by one IMU sample into the history.
  void propagate(const ImuSample& imu) { tracker_.history().add_imu(imu); }
  /// Γ_k: posterior update at time t with a measurement model, writing the history at t.
  UpdateResult update(MeasurementModel& model, double t) { return updater_.update(model, tracker_.history(), t); }
  /// x̂(t): state and covariance at any time the history covers.
  StateQuery query(double t) const { return tracker_.history().query(t); }
  /// An IMU stamp on the state's clock, the LiDAR's (less the LiDAR-IMU time offset).
  double state_time(double t_imu) const { return tracker_.state_time(t_imu); }

  bool initialised() const { return tracker_.initialised(); }
  /// x̂ at the newest time the history holds (status kNotInitialised before initialisation).
  StateQuery latest() const { return initialised() ? query(tracker_.history().newest_time()) : StateQuery{}; }
  /// Replaces the map by these world-frame points (a saved map to localize on or extend).
  void load_map(const std::vector<Eigen::Vector3f>& points) {
    updater_.reset_map();
    updater_.map().insert(points);
  }
  /// Starts the session anywhere in a saved map (world-frame points): the estimator runs in its own
  /// frame S and searches the map for itself (MapLocalization), around `initial_pose` when given;
  /// once found, its history moves into the map's frame, the saved map replaces the session's
  /// and the next estimator.global_localization.confirm_s of scans must fit it. Nothing is written
  /// to the map until then. `map_gravity`: the gravity direction the map recorded, if any. Throws
  /// std::invalid_argument when the map cannot be searched (too large, or its gravity farther
  /// than global_localization.max_map_tilt from its −z).
  void localize_in(std::vector<Eigen::Vector3f> points, const std::optional<InitialPose>& initial_pose = std::nullopt,
                   const std::optional<Eigen::Vector3d>& map_gravity = std::nullopt);
  /// The search for the start in a saved map (nullptr without localize_in).
  const MapLocalization* map_localization() const { return localization_ ? &localization_->search() : nullptr; }
  /// T_M_S: where the session frame lies in the saved map's (identity until a location is taken).
  Eigen::Isometry3d T_map_session() const {
    return localization_ ? localization_->T_map_session() : Eigen::Isometry3d::Identity();
  }
  /// In the saved map's frame and confirmed there (always, without localize_in).
  bool localized() const { return !localization_ || localization_->localized(); }
  const SpatialIndex& map() const { return updater_.map(); }
  /// Counts of refused and flagged input, from both sides.
  std::map<std::string, std::uint64_t> counters() const;
  const EstimatorConfig& config() const { return config_; }
  /// Scans refused before they reached the estimator (the source's checks): they arrived, so they
  /// count as time without a LiDAR update for the tracking status.
  void note_refused_scans(std::size_t n) {
    if (!initialised()) return;
    for (std::size_t i = 0; i < n; ++i) monitor_.on_refused_scan();
  }
  /// tracking / relocalizing / lost, with the reason and the episodes so far.
  const TrackingMonitor& tracking() const { return monitor_; }

 private:
  /// Hands the tracker's gap, clock-step and restart events to the monitor.
  void forward_events();
  /// After a scan's LiDAR step while localize_in's search runs: feeds it, takes a location it
  /// found (moving the history and the map), and confirms or drops a location taken.
  void localize_step(const ScanReport& report);
  /// Lost and found: a track lost for global_localization.lost_search_after_s searches its map; on
  /// a saved map, so does a clock step (the sensor may have moved any distance).
  void search_when_lost(double t);

  EstimatorConfig config_;
  StateTracker tracker_;
  LidarUpdater updater_;
  TrackingMonitor monitor_;
  TimeGate scan_gate_;
  Counters counters_;  ///< scan checks
  std::unique_ptr<SessionLocalization> localization_;
  std::optional<Eigen::Vector3d> map_gravity_;  ///< the loaded map's, when it recorded it
  bool saved_map_ = false;  ///< localize_in was called: the session runs on a saved map
  bool jumped_ = false;     ///< a clock step since the last scan (searched at once on a saved map)
  bool unsearchable_ = false;  ///< a lost search found the map cannot be searched: not tried again
};

/// Checks a scan before the LiDAR step: its times, the state's initialisation, and its end against
/// the scan stream (`gate`, with the history's newest time as the reference clock that decides a
/// jump). Returns false (counted in `counters`) when it must be skipped. The Estimator's; a service
/// that holds the history can call it the same way.
bool accept_scan(const LidarScan& scan, TimeGate& gate, const StateHistory& history, Counters& counters);

}  // namespace fuse

// The FUSE estimation interface (DESIGN §1): ingest, propagate, update, query over one time base,
// with the four roles plugged in by config: temporal (StateHistory), spatial (SpatialIndex +
// Associator), inference (UpdateBackend) and functional (MapPolicy).
//
// The single-process composition of the two sides the services split between them:
// StateTracker (IMU checks, initialisation, propagation: fuse-state) and LidarUpdater (one LiDAR
// step on a history: fuse-update). One scan: check it, make sure the history has an entry at
// its end t_e, run the LiDAR step there (which corrects the history at t_e and re-propagates the
// later IMU), check for divergence.
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "fuse/estimation/estimator_config.hpp"
#include "fuse/estimation/lidar_updater.hpp"
#include "fuse/estimation/state_tracker.hpp"

namespace fuse {

class Estimator {
 public:
  explicit Estimator(const EstimatorConfig& config);

  /// D_in: checks and routes one IMU sample (→ propagate).
  void ingest(const ImuSample& imu) { tracker_.ingest(imu); }
  /// D_in: checks one scan and runs the LiDAR step; returns its report. Throws DivergenceError.
  ScanReport ingest(const LidarScan& scan);
  /// Φ_k: propagation by one IMU sample into the history.
  void propagate(const ImuSample& imu) { tracker_.history().add_imu(imu); }
  /// Γ_k: posterior update at time t with a measurement model, writing the history at t.
  UpdateResult update(MeasurementModel& model, double t) { return updater_.update(model, tracker_.history(), t); }
  /// x̂(t): state and covariance at any time the history covers.
  StateQuery query(double t) const { return tracker_.history().query(t); }

  bool initialised() const { return tracker_.initialised(); }
  /// Replaces the map by these world-frame points (a saved map to localize on or extend).
  void load_map(const std::vector<Eigen::Vector3f>& points) {
    updater_.reset_map();
    updater_.map().insert(points);
  }
  const SpatialIndex& map() const { return updater_.map(); }
  /// Counts of refused and flagged input, from both sides.
  std::map<std::string, std::uint64_t> counters() const;
  const EstimatorConfig& config() const { return config_; }

 private:
  EstimatorConfig config_;
  StateTracker tracker_;
  LidarUpdater updater_;
  Counters counters_;  ///< scan checks
  double last_scan_t_ = -1.0;
};

/// Checks a scan against the previous one and the history before the LiDAR step (shared by the
/// Estimator and fuse-update). Returns false (counted in `counters`) when it must be skipped.
bool accept_scan(const LidarScan& scan, double last_scan_t, const StateHistory& history, double max_imu_gap,
                 Counters& counters);

}  // namespace fuse

// The FUSE estimation interface (DESIGN §1): ingest, propagate, update, query over one time base,
// with the four roles plugged in by config: temporal (StateHistory), spatial (SpatialIndex +
// Associator), inference (UpdateBackend) and functional (MapPolicy).
//
// One LiDAR step (process_scan), in order:
//   1. propagate the history to the scan end t_e            (temporal)
//   2. range filter + voxel downsample the raw points
//   3. deskew each kept point through the history            (temporal)
//   4. associate against the map, screen, update at t_e     (spatial + inference)
//   5. replace the history entry at t_e, re-propagate later IMU
//   6. offer the world-frame points to the map policy        (functional)
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "fuse/association/associator.hpp"
#include "fuse/association/spatial_index.hpp"
#include "fuse/association/voxel_filter.hpp"
#include "fuse/core/config.hpp"
#include "fuse/core/types.hpp"
#include "fuse/estimation/deskew.hpp"
#include "fuse/estimation/imu_propagation.hpp"
#include "fuse/estimation/point_to_plane_model.hpp"
#include "fuse/estimation/state_history.hpp"
#include "fuse/estimation/static_initializer.hpp"
#include "fuse/estimation/update_backend.hpp"
#include "fuse/map/map_policy.hpp"

namespace fuse {

/// The filter can no longer be trusted (NaN, covariance blow-up, no constraints for too long).
class DivergenceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct PreprocessConfig {
  double min_range = 0.5;    ///< m: closer returns (the sensor's blind zone, the carrier) are dropped
  double max_range = 60.0;   ///< m
  double voxel_size = 0.5;   ///< m: downsampling before deskew and association
  /// Cap on the points kept per scan: when the voxel filter keeps more, the voxel is enlarged
  /// (by √(kept/max), up to kMaxVoxelGrowth times) so the per-scan cost stays bounded on dense
  /// or open scenes whatever the sensor.
  std::size_t max_points = 3000;
  bool deskew = true;        ///< ablation switch
  void load(ConfigNode& node);
};

struct InitialCovarianceConfig {
  double position_std = 1e-3;        ///< m
  double roll_pitch_std = 0.02;      ///< rad
  double yaw_std = 1e-3;             ///< rad
  double velocity_std = 0.01;        ///< m/s (starts at rest)
  double gyro_bias_std = 0.005;      ///< rad/s
  double accel_bias_std = 0.1;       ///< m/s²
  double extrinsic_rotation_std = 0.01;     ///< rad, when estimated
  double extrinsic_translation_std = 0.01;  ///< m, when estimated
  double gravity_std = 0.01;         ///< rad, when estimated
  void load(ConfigNode& node);
};

struct DivergenceConfig {
  double max_position_std = 50.0;       ///< m: larger means the filter lost track
  int max_scans_without_constraints = 50;
  double max_imu_gap = 0.1;             ///< s: a larger gap between IMU samples is flagged (data gap)
  void load(ConfigNode& node);
};

struct EstimatorConfig {
  double gravity_magnitude = 9.81;
  bool estimate_extrinsic = false;
  bool estimate_gravity = false;
  Eigen::Isometry3d T_imu_lidar = Eigen::Isometry3d::Identity();
  StaticInitConfig init;
  ImuNoiseConfig imu;
  StateHistoryConfig history;
  PreprocessConfig preprocess;
  AssociationConfig association;
  PointToPlaneModel::Config measurement;
  UpdateConfig update;
  SpatialIndexConfig index;
  MapPolicyConfig map;
  InitialCovarianceConfig initial_covariance;
  DivergenceConfig divergence;
  /// Reads the `estimator` section of a config file (unknown keys are refused).
  void load(ConfigNode& node);
};

/// Per-scan diagnostics and timing (written by the runner to timing.csv / diagnostics.csv).
struct ScanReport {
  double t = 0.0;
  std::uint64_t sequence = 0;
  bool updated = false;
  std::size_t points_in = 0, points_kept = 0;
  std::size_t constraints = 0, rejected_no_neighbors = 0, rejected_not_planar = 0, rejected_screening = 0;
  int iterations = 0;
  bool converged = false;
  double min_eig_translation = 0.0, min_eig_rotation = 0.0, min_gamma = 1.0, min_eig_ratio = 1.0;
  std::size_t map_points = 0, map_inserted = 0;
  double ms_deskew = 0.0, ms_association = 0.0, ms_update = 0.0, ms_map = 0.0, ms_total = 0.0;
};

class Estimator {
 public:
  explicit Estimator(const EstimatorConfig& config);

  /// D_in: checks and routes one IMU sample (→ propagate).
  void ingest(const ImuSample& imu);
  /// D_in: checks one scan and runs the LiDAR step; returns its report. Throws DivergenceError.
  ScanReport ingest(const LidarScan& scan);
  /// Φ_k: propagation by one IMU sample into the history.
  void propagate(const ImuSample& imu);
  /// Γ_k: posterior update at time t with a measurement model, writing the history at t.
  UpdateResult update(MeasurementModel& model, double t);
  /// x̂(t): state and covariance at any time the history covers.
  StateQuery query(double t) const;

  bool initialised() const { return history_.initialised(); }
  const SpatialIndex& map() const { return *map_; }
  const std::map<std::string, std::uint64_t>& counters() const { return counters_; }
  const EstimatorConfig& config() const { return config_; }

 private:
  void initialise(const NavState& x0, const ImuSample& imu);
  void count(const std::string& reason, const std::string& message);
  void check_divergence(const ScanReport& report);

  EstimatorConfig config_;
  StaticInitializer initializer_;
  StateHistory history_;
  std::unique_ptr<SpatialIndex> map_;
  std::unique_ptr<UpdateBackend> backend_;
  std::unique_ptr<MapPolicy> map_policy_;
  Associator associator_;
  VoxelFilter voxel_filter_;
  float voxel_size_;  ///< downsampling voxel in use (adapts to max_points)
  void downsample();
  void order_spatially();
  Deskewer deskewer_;

  double last_imu_t_ = -1.0;
  double last_scan_t_ = -1.0;
  int scans_without_constraints_ = 0;
  std::map<std::string, std::uint64_t> counters_;
  // Per-scan buffers reused to avoid allocation on the hot path.
  std::vector<Eigen::Vector3f> raw_, points_L_, points_W_;
  std::vector<std::uint32_t> in_range_, kept_, kept_raw_;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed_;
  ConstraintSet constraints_;
};

}  // namespace fuse

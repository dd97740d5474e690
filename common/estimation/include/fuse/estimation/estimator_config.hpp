// Configuration of the FUSE LiDAR-inertial estimator: one struct per module, the whole read
// from the `estimator` section of a config file.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include "fuse/association/associator.hpp"
#include "fuse/association/spatial_index.hpp"
#include "fuse/core/config.hpp"
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
  /// Unmodelled motion across a data gap of length Δt (nothing measured it): the covariance grows
  /// by (½σ_a Δt²)² in position, (σ_a Δt)² in velocity and (σ_ω Δt)² in rotation, so the LiDAR
  /// updates after the gap may pull the state back instead of trusting the coasted prediction.
  double gap_accel_std = 1.0;           ///< σ_a, m/s²
  double gap_gyro_std = 0.5;            ///< σ_ω, rad/s
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

}  // namespace fuse

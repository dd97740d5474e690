#include "fuse/estimation/estimator_config.hpp"

#include <cmath>

namespace fuse {

void PreprocessConfig::load(ConfigNode& node) {
  node.get("min_range", min_range).get("max_range", max_range).get("voxel_size", voxel_size).get("deskew", deskew);
  node.get("max_points", max_points);
  node.check(max_points >= 100, "max_points", "must be at least 100");
  node.check(min_range >= 0.0, "min_range", "must be >= 0");
  node.check(max_range > min_range, "max_range", "must be greater than min_range");
  // The voxel filter's keys hold ±2²⁰ voxels: 1,000 m at the smallest voxel is 10⁵ of them.
  node.check(max_range <= 1000.0, "max_range", "must be at most 1000 m");
  node.check(voxel_size >= 0.01 && voxel_size <= 5.0, "voxel_size", "must be in [0.01, 5] m");
  node.finish();
}

void InitialCovarianceConfig::load(ConfigNode& node) {
  node.get("position_std", position_std).get("roll_pitch_std", roll_pitch_std).get("yaw_std", yaw_std);
  node.get("velocity_std", velocity_std).get("gyro_bias_std", gyro_bias_std).get("accel_bias_std", accel_bias_std);
  node.get("extrinsic_rotation_std", extrinsic_rotation_std).get("extrinsic_translation_std", extrinsic_translation_std);
  node.get("gravity_std", gravity_std);
  for (double v : {position_std, roll_pitch_std, yaw_std, velocity_std, gyro_bias_std, accel_bias_std,
                   extrinsic_rotation_std, extrinsic_translation_std, gravity_std}) {
    node.check(std::isfinite(v) && v > 0.0, "*_std", "every standard deviation must be positive and finite");
  }
  node.finish();
}

void TimeOffsetConfig::load(ConfigNode& node) {
  node.get("initial_s", initial_s).get("estimate", estimate).get("std_s", std_s).get("max_s", max_s);
  node.get("random_walk", random_walk).get("hold_after_relocalisation_s", hold_after_relocalisation_s);
  node.get("rate_smoothing_s", rate_smoothing_s);
  node.check(std::isfinite(rate_smoothing_s) && rate_smoothing_s >= 0.0 && rate_smoothing_s <= 1.0, "rate_smoothing_s",
             "must be in [0, 1] s");
  node.check(std::isfinite(hold_after_relocalisation_s) && hold_after_relocalisation_s >= 0.0 &&
                 hold_after_relocalisation_s <= 60.0,
             "hold_after_relocalisation_s", "must be in [0, 60] s");
  node.check(std::isfinite(max_s) && max_s > 0.0 && max_s <= 1.0, "max_s", "must be in (0, 1] s");
  node.check(std::isfinite(initial_s) && std::abs(initial_s) <= max_s, "initial_s", "must be within ±max_s");
  node.check(std::isfinite(std_s) && std_s > 0.0 && std_s <= 1.0, "std_s", "must be in (0, 1] s");
  node.check(std::isfinite(random_walk) && random_walk >= 0.0, "random_walk", "must be finite and >= 0");
  node.finish();
}

void DivergenceConfig::load(ConfigNode& node) {
  node.get("max_position_std", max_position_std).get("max_scans_without_constraints", max_scans_without_constraints);
  node.get("max_imu_gap", max_imu_gap).get("gap_accel_std", gap_accel_std).get("gap_gyro_std", gap_gyro_std);
  node.get("gap_rate_window", gap_rate_window).get("gap_level", gap_level).get("coast_silent_imu", coast_silent_imu);
  node.get("unknown_gap_s", unknown_gap_s);
  node.check(std::isfinite(unknown_gap_s) && unknown_gap_s > 0.0 && unknown_gap_s <= 60.0, "unknown_gap_s",
             "must be in (0, 60] s");
  node.check(std::isfinite(gap_rate_window) && gap_rate_window >= 0.0 && gap_rate_window <= 10.0, "gap_rate_window",
             "must be in [0, 10] s");
  node.check(std::isfinite(gap_accel_std) && gap_accel_std >= 0.0, "gap_accel_std", "must be finite and >= 0");
  node.check(std::isfinite(gap_gyro_std) && gap_gyro_std >= 0.0, "gap_gyro_std", "must be finite and >= 0");
  node.check(max_position_std > 0.0, "max_position_std", "must be positive");
  node.check(max_scans_without_constraints >= 1, "max_scans_without_constraints", "must be >= 1");
  node.check(max_imu_gap > 0.0, "max_imu_gap", "must be positive");
  node.finish();
}

void RecoveryConfig::load(ConfigNode& node) {
  node.get("enabled", enabled).get("position_std", position_std).get("rotation_std", rotation_std);
  node.get("max_iterations", max_iterations).get("reassociate_iterations", reassociate_iterations);
  node.get("heading_hypotheses", heading_hypotheses).get("inlier_residual", inlier_residual);
  node.get("heading_margin", heading_margin).get("min_fit", min_fit).get("map_hold_distance", map_hold_distance);
  node.get("map_hold_radius", map_hold_radius).get("turn_through_gap", turn_through_gap).get("commit_fit", commit_fit);
  node.get("min_measured_fraction", min_measured_fraction);
  node.get("ambiguity_angle", ambiguity_angle).get("ambiguity_fit", ambiguity_fit);
  node.check(std::isfinite(position_std) && position_std > 0.0, "position_std", "must be positive and finite");
  node.check(std::isfinite(rotation_std) && rotation_std > 0.0, "rotation_std", "must be positive and finite");
  node.check(max_iterations >= 1 && max_iterations <= 50, "max_iterations", "must be in [1, 50]");
  node.check(reassociate_iterations >= 1 && reassociate_iterations <= max_iterations, "reassociate_iterations",
             "must be in [1, max_iterations]");
  node.check(heading_hypotheses >= 1 && heading_hypotheses <= 72, "heading_hypotheses", "must be in [1, 72]");
  node.check(std::isfinite(inlier_residual) && inlier_residual > 0.0, "inlier_residual", "must be positive and finite");
  node.check(std::isfinite(heading_margin) && heading_margin >= 0.0 && heading_margin < 1.0, "heading_margin",
             "must be in [0, 1)");
  node.check(std::isfinite(min_fit) && min_fit >= 0.0 && min_fit <= 1.0, "min_fit", "must be in [0, 1]");
  node.check(std::isfinite(commit_fit) && commit_fit >= 0.0 && commit_fit <= 1.0, "commit_fit", "must be in [0, 1]");
  node.check(std::isfinite(min_measured_fraction) && min_measured_fraction >= 0.0 && min_measured_fraction <= 1.0,
             "min_measured_fraction", "must be in [0, 1]");
  node.check(std::isfinite(ambiguity_angle) && ambiguity_angle > 0.0 && ambiguity_angle <= M_PI, "ambiguity_angle",
             "must be in (0, pi] rad");
  node.check(std::isfinite(ambiguity_fit) && ambiguity_fit >= 0.0 && ambiguity_fit <= 1.0, "ambiguity_fit", "must be in [0, 1]");
  node.check(std::isfinite(map_hold_distance) && map_hold_distance >= 0.0 && map_hold_distance <= 100.0,
             "map_hold_distance", "must be in [0, 100] m");
  node.check(std::isfinite(map_hold_radius) && map_hold_radius >= 0.0, "map_hold_radius", "must be finite and >= 0 m");
  node.finish();
}

void EstimatorConfig::load(ConfigNode& node) {
  node.get("gravity_magnitude", gravity_magnitude).get("estimate_extrinsic", estimate_extrinsic);
  node.get("estimate_gravity", estimate_gravity);
  node.check(gravity_magnitude > 9.0 && gravity_magnitude < 10.5, "gravity_magnitude", "must be in (9, 10.5) m/s^2");
  {
    auto ext = node.child("extrinsic");
    Eigen::Vector3d t = T_imu_lidar.translation();
    Eigen::Quaterniond q0(T_imu_lidar.linear());
    Eigen::Vector4d q(q0.x(), q0.y(), q0.z(), q0.w());
    ext.get("translation", t).get("rotation_xyzw", q);
    ext.check(std::abs(q.norm() - 1.0) < 1e-3, "rotation_xyzw", "must be a unit quaternion (x, y, z, w)");
    ext.finish();
    T_imu_lidar.setIdentity();
    T_imu_lidar.linear() = Eigen::Quaterniond(q(3), q(0), q(1), q(2)).normalized().toRotationMatrix();
    T_imu_lidar.translation() = t;
  }
  load_section(node, "extrinsic_excitation", extrinsic_excitation);
  load_section(node, "init", init);
  load_section(node, "imu_noise", imu);
  load_section(node, "history", history);
  load_section(node, "preprocess", preprocess);
  load_section(node, "association", association);
  load_section(node, "measurement", measurement);
  load_section(node, "update", update);
  load_section(node, "spatial_index", index);
  load_section(node, "map", map);
  load_section(node, "initial_covariance", initial_covariance);
  load_section(node, "time_offset", time_offset);
  imu.time_offset_random_walk = time_offset.estimate ? time_offset.random_walk : 0.0;
  imu.time_offset_rate_smoothing_s = time_offset.rate_smoothing_s;
  load_section(node, "zero_velocity", zero_velocity);
  load_section(node, "divergence", divergence);
  load_section(node, "recovery", recovery);
  load_section(node, "clock", clock);
  load_section(node, "tracking", tracking);
  load_section(node, "global_localization", global_localization);
  node.finish();
}

}  // namespace fuse

#include "fuse/estimation/estimator.hpp"

#include <chrono>
#include <cmath>

#include "fuse/core/logging.hpp"

namespace fuse {

namespace {
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
}  // namespace

void PreprocessConfig::load(ConfigNode& node) {
  node.get("min_range", min_range).get("max_range", max_range).get("voxel_size", voxel_size).get("deskew", deskew);
  node.get("max_points", max_points);
  node.check(max_points >= 100, "max_points", "must be at least 100");
  node.check(min_range >= 0.0, "min_range", "must be >= 0");
  node.check(max_range > min_range, "max_range", "must be greater than min_range");
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

void DivergenceConfig::load(ConfigNode& node) {
  node.get("max_position_std", max_position_std).get("max_scans_without_constraints", max_scans_without_constraints);
  node.get("max_imu_gap", max_imu_gap);
  node.check(max_position_std > 0.0, "max_position_std", "must be positive");
  node.check(max_scans_without_constraints >= 1, "max_scans_without_constraints", "must be >= 1");
  node.check(max_imu_gap > 0.0, "max_imu_gap", "must be positive");
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
  load_section(node, "divergence", divergence);
  node.finish();
}

Estimator::Estimator(const EstimatorConfig& config)
    : config_(config),
      initializer_(config.init),
      history_(config.history, config.imu),
      map_(make_spatial_index(config.index)),
      backend_(make_update_backend(config.update)),
      map_policy_(make_map_policy(config.map)),
      associator_(config.association),
      voxel_size_(static_cast<float>(config.preprocess.voxel_size)) {
  config_.measurement.extrinsic_jacobian = config.estimate_extrinsic;
}

void Estimator::count(const std::string& reason, const std::string& message) {
  const auto n = ++counters_[reason];
  // Log the first occurrences and then every 100th, so a flood of bad input stays readable.
  if (n <= 5 || n % 100 == 0) logger("estimator")->warn("{} (#{} '{}')", message, n, reason);
}

void Estimator::ingest(const ImuSample& imu) {
  if (!imu.gyro.allFinite() || !imu.accel.allFinite() || !std::isfinite(imu.t)) {
    count("imu_not_finite", "IMU sample with a non-finite value refused");
    return;
  }
  if (last_imu_t_ >= 0.0 && imu.t <= last_imu_t_) {
    count("imu_time_not_increasing", "IMU sample at t=" + std::to_string(imu.t) + " not after the previous one, refused");
    return;
  }
  if (last_imu_t_ >= 0.0 && imu.t - last_imu_t_ > config_.divergence.max_imu_gap) {
    count("imu_gap", "IMU data gap of " + std::to_string(imu.t - last_imu_t_) + " s before t=" + std::to_string(imu.t));
  }
  last_imu_t_ = imu.t;
  if (!history_.initialised()) {
    if (auto x0 = initializer_.add(imu, config_.gravity_magnitude)) initialise(*x0, imu);
    return;
  }
  propagate(imu);
}

void Estimator::initialise(const NavState& x0_in, const ImuSample& imu) {
  NavState x0 = x0_in;
  x0.R_IL = config_.T_imu_lidar.linear();
  x0.p_IL = config_.T_imu_lidar.translation();
  const auto& c = config_.initial_covariance;
  StateCovariance P = StateCovariance::Zero();
  auto set = [&P](int idx, int n, double std) { P.block(idx, idx, n, n) = Eigen::MatrixXd::Identity(n, n) * std * std; };
  set(Idx::kPos, 3, c.position_std);
  P.block<3, 3>(Idx::kRot, Idx::kRot) = Eigen::Vector3d(c.roll_pitch_std * c.roll_pitch_std, c.roll_pitch_std * c.roll_pitch_std,
                                                        c.yaw_std * c.yaw_std).asDiagonal();
  set(Idx::kVel, 3, c.velocity_std);
  set(Idx::kBg, 3, c.gyro_bias_std);
  set(Idx::kBa, 3, c.accel_bias_std);
  if (config_.estimate_extrinsic) {
    set(Idx::kExtRot, 3, c.extrinsic_rotation_std);
    set(Idx::kExtPos, 3, c.extrinsic_translation_std);
  }
  if (config_.estimate_gravity) set(Idx::kGrav, 2, c.gravity_std);
  history_.reset(imu.t, x0, P, imu);
  logger("estimator")->info("initialised at t={:.3f}: gyro bias [{:.5f} {:.5f} {:.5f}] rad/s after {} restarts", imu.t,
                            x0.bg.x(), x0.bg.y(), x0.bg.z(), initializer_.restarts());
}

void Estimator::propagate(const ImuSample& imu) { history_.add_imu(imu); }

UpdateResult Estimator::update(MeasurementModel& model, double t) {
  StateQuery prior = history_.query(t);
  UpdateResult result = backend_->update(prior.x, prior.P, model);
  if (result.updated) history_.correct(t, prior.x, prior.P);
  return result;
}

StateQuery Estimator::query(double t) const { return history_.query(t); }

ScanReport Estimator::ingest(const LidarScan& scan) {
  const auto t0 = Clock::now();
  ScanReport report;
  report.t = scan.t_end;
  report.sequence = scan.sequence;
  report.points_in = scan.points.size();
  if (!std::isfinite(scan.t_start) || !std::isfinite(scan.t_end) || scan.t_end < scan.t_start) {
    count("scan_bad_time", "scan with invalid start/end time refused");
    return report;
  }
  if (!history_.initialised()) {
    count("scan_before_init", "scan before static initialisation finished, skipped");
    return report;
  }
  if (scan.t_end <= last_scan_t_) {
    count("scan_out_of_order", "scan ending at t=" + std::to_string(scan.t_end) + " is not newer than the last one, refused");
    return report;
  }
  if (scan.t_end > history_.newest().t + config_.divergence.max_imu_gap) {
    count("scan_ahead_of_imu", "scan ends " + std::to_string(scan.t_end - history_.newest().t) +
                                   " s after the newest IMU sample: extrapolating");
  }
  if (!history_.ensure_entry(scan.t_end)) {
    count("scan_too_old", "scan older than the state history, refused");
    return report;
  }
  last_scan_t_ = scan.t_end;

  // 2. Range filter and voxel downsampling on the raw (LiDAR frame) points.
  const double min_r2 = config_.preprocess.min_range * config_.preprocess.min_range;
  const double max_r2 = config_.preprocess.max_range * config_.preprocess.max_range;
  raw_.clear();
  in_range_.clear();
  for (std::uint32_t i = 0; i < scan.points.size(); ++i) {
    const LidarPoint& p = scan.points[i];
    const Eigen::Vector3f v(p.x, p.y, p.z);
    const double r2 = v.squaredNorm();
    if (!v.allFinite() || r2 < min_r2 || r2 > max_r2) continue;
    raw_.push_back(v);
    in_range_.push_back(i);
  }
  downsample();
  order_spatially();
  report.points_kept = kept_raw_.size();
  if (kept_raw_.empty()) {
    count("scan_empty", "scan with no usable point at t=" + std::to_string(scan.t_end));
    check_divergence(report);
    return report;
  }

  // 3. Deskew through the history (or take the points as measured).
  auto t_stage = Clock::now();
  const StateQuery prior = history_.query(scan.t_end);
  const Eigen::Isometry3d T_IL = prior.x.T_IL();
  const bool deskew = config_.preprocess.deskew && deskewer_.prepare(history_, scan.t_start, scan.t_end);
  if (config_.preprocess.deskew && !deskew) {
    count("deskew_without_history", "scan start is not covered by the state history: points used as measured");
  }
  if (deskew) {
    deskewer_.apply(scan, kept_raw_, T_IL, points_L_);
  } else {
    points_L_.resize(kept_raw_.size());
    for (std::size_t i = 0; i < kept_raw_.size(); ++i) {
      const LidarPoint& p = scan.points[kept_raw_[i]];
      points_L_[i] = Eigen::Vector3f(p.x, p.y, p.z);
    }
  }
  report.ms_deskew = ms_since(t_stage);

  // 4-5. Associate + update at the scan end (the first scan only seeds the map).
  t_stage = Clock::now();
  NavState x = prior.x;
  if (map_->size() > 0) {
    PointToPlaneModel model(config_.measurement, points_L_, *map_, associator_, constraints_);
    const UpdateResult result = update(model, scan.t_end);
    x = history_.query(scan.t_end).x;
    report.updated = result.updated;
    report.iterations = result.iterations;
    report.converged = result.converged;
    report.constraints = constraints_.constraints.size();
    report.rejected_no_neighbors = constraints_.rejected_no_neighbors;
    report.rejected_not_planar = constraints_.rejected_not_planar;
    report.rejected_screening = constraints_.rejected_screening;
    report.min_eig_translation = result.degeneracy.min_eigenvalue_translation;
    report.min_eig_rotation = result.degeneracy.min_eigenvalue_rotation;
    report.min_gamma = result.degeneracy.min_gamma;
    report.min_eig_ratio = result.degeneracy.min_ratio;
    report.ms_association = model.association_ms();
  }
  report.ms_update = ms_since(t_stage) - report.ms_association;

  // 6. Map policy on the world-frame points at the posterior.
  t_stage = Clock::now();
  const Eigen::Isometry3d T_WL = x.T_WI() * x.T_IL();
  const Eigen::Matrix3f R = T_WL.linear().cast<float>();
  const Eigen::Vector3f t = T_WL.translation().cast<float>();
  points_W_.resize(points_L_.size());
  for (std::size_t i = 0; i < points_L_.size(); ++i) points_W_[i] = R * points_L_[i] + t;
  // The association's nearest-neighbour distances are reused when it ran on this scan's points.
  const bool have_nearest = report.updated && constraints_.nearest_dist2.size() == points_W_.size();
  const MapUpdateStats map_stats =
      map_policy_->apply(points_W_, *map_, have_nearest ? &constraints_.nearest_dist2 : nullptr);
  report.map_inserted = map_stats.inserted;
  report.map_points = map_->size();
  report.ms_map = ms_since(t_stage);
  report.ms_total = ms_since(t0);
  check_divergence(report);
  return report;
}

void Estimator::downsample() {
  // Voxel grid at the size the previous scan needed (never below the configured size); enlarge it
  // while the scan keeps more than max_points, and relax it back when a scan keeps far fewer.
  constexpr int kMaxVoxelGrowth = 4;
  constexpr float kGrowthMargin = 1.05f;  // aim a little below max_points
  constexpr float kRelax = 0.9f;          // per-scan shrink towards the configured size
  const float configured = static_cast<float>(config_.preprocess.voxel_size);
  const auto max_points = static_cast<float>(config_.preprocess.max_points);
  voxel_filter_.filter(raw_, voxel_size_, kept_);
  for (int i = 0; i < kMaxVoxelGrowth && static_cast<float>(kept_.size()) > max_points; ++i) {
    voxel_size_ *= kGrowthMargin * std::sqrt(static_cast<float>(kept_.size()) / max_points);
    voxel_filter_.filter(raw_, voxel_size_, kept_);
  }
  if (static_cast<float>(kept_.size()) < 0.5f * max_points) voxel_size_ = std::max(configured, kRelax * voxel_size_);
}

void Estimator::order_spatially() {
  // Map queries of neighbouring points touch the same voxels: visiting points in Morton (Z-order)
  // of 1 m cells keeps those voxels in cache, which matters more than anything else for speed on
  // large maps. The order does not change the result beyond floating-point summation order.
  constexpr float kCell = 1.0f;
  auto spread = [](std::uint32_t v) {  // interleave the low 10 bits with two zero bits each
    std::uint64_t x = v & 0x3ff;
    x = (x | (x << 16)) & 0x030000FF;
    x = (x | (x << 8)) & 0x0300F00F;
    x = (x | (x << 4)) & 0x030C30C3;
    x = (x | (x << 2)) & 0x09249249;
    return x;
  };
  keyed_.resize(kept_.size());
  for (std::size_t i = 0; i < kept_.size(); ++i) {
    const Eigen::Vector3f& p = raw_[kept_[i]];
    const auto cx = static_cast<std::uint32_t>(static_cast<std::int32_t>(std::floor(p.x() / kCell)) + 512);
    const auto cy = static_cast<std::uint32_t>(static_cast<std::int32_t>(std::floor(p.y() / kCell)) + 512);
    const auto cz = static_cast<std::uint32_t>(static_cast<std::int32_t>(std::floor(p.z() / kCell)) + 512);
    keyed_[i] = {spread(cx) | (spread(cy) << 1) | (spread(cz) << 2), in_range_[kept_[i]]};
  }
  std::sort(keyed_.begin(), keyed_.end());
  kept_raw_.resize(keyed_.size());
  for (std::size_t i = 0; i < keyed_.size(); ++i) kept_raw_[i] = keyed_[i].second;
}

void Estimator::check_divergence(const ScanReport& report) {
  const StateQuery q = history_.query(report.t);
  if (!q.x.all_finite() || !q.P.allFinite()) {
    throw DivergenceError("state or covariance became non-finite at t=" + std::to_string(report.t));
  }
  const double pos_std = std::sqrt(q.P.block<3, 3>(Idx::kPos, Idx::kPos).trace());
  if (pos_std > config_.divergence.max_position_std) {
    throw DivergenceError("position standard deviation " + std::to_string(pos_std) + " m exceeds divergence.max_position_std at t=" +
                          std::to_string(report.t));
  }
  if (map_->size() > 0 && report.constraints == 0) {
    if (++scans_without_constraints_ > config_.divergence.max_scans_without_constraints) {
      throw DivergenceError("no LiDAR constraints for " + std::to_string(scans_without_constraints_) +
                            " consecutive scans at t=" + std::to_string(report.t));
    }
  } else {
    scans_without_constraints_ = 0;
  }
}

}  // namespace fuse

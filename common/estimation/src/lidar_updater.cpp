#include "fuse/estimation/lidar_updater.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>

#include "fuse/core/logging.hpp"

namespace fuse {

namespace {
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

UpdateConfig with_recovery_caps(UpdateConfig c, const RecoveryConfig& r) {
  c.max_iterations = r.max_iterations;
  c.nano.max_iterations = r.max_iterations;
  return c;
}

AssociationConfig without_screening(AssociationConfig c) {
  c.screening = false;
  return c;
}
}  // namespace

LidarUpdater::LidarUpdater(const EstimatorConfig& config)
    : config_(config),
      map_(make_spatial_index(config.index)),
      backend_(make_update_backend(config.update)),
      recovery_backend_(make_update_backend(with_recovery_caps(config.update, config.recovery))),
      map_policy_(make_map_policy(config.map)),
      associator_(config.association),
      recovery_associator_(without_screening(config.association)),
      recovery_measurement_(config.measurement),
      voxel_size_(static_cast<float>(config.preprocess.voxel_size)),
      counters_(logger("estimator")) {
  config_.measurement.extrinsic_jacobian = config.estimate_extrinsic;
  recovery_measurement_.extrinsic_jacobian = config.estimate_extrinsic;
  recovery_measurement_.reassociate_iterations = config.recovery.reassociate_iterations;
}

bool LidarUpdater::needs_recovery(const StateCovariance& P) const {
  if (!config_.recovery.enabled) return false;
  // Largest σ of each block: the square root of the largest eigenvalue of its 3×3 covariance.
  auto largest_std = [&P](int idx) {
    const Eigen::Matrix3d block = P.block<3, 3>(idx, idx);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(block, Eigen::EigenvaluesOnly);
    return std::sqrt(std::max(es.eigenvalues()(2), 0.0));
  };
  return largest_std(Idx::kPos) > config_.recovery.position_std ||
         largest_std(Idx::kRot) > config_.recovery.rotation_std;
}

void LidarUpdater::set_map_mode(const std::string& mode) {
  MapPolicyConfig c = config_.map;
  c.mode = mode;
  map_policy_ = make_map_policy(c);
  config_.map = c;
}

UpdateResult LidarUpdater::update(MeasurementModel& model, StateHistory& history, double t) {
  StateQuery prior = history.query(t);
  UpdateBackend& backend = needs_recovery(prior.P) ? *recovery_backend_ : *backend_;
  UpdateResult result = backend.update(prior.x, prior.P, model);
  if (result.updated) history.correct(t, prior.x, prior.P);
  return result;
}

ScanReport LidarUpdater::process(const LidarScan& scan, StateHistory& history) {
  const auto t0 = Clock::now();
  ScanReport report;
  report.t = scan.t_end;
  report.sequence = scan.sequence;
  report.points_in = scan.points.size();
  points_W_.clear();
  // 1. Range filter and voxel downsampling on the raw (LiDAR frame) points.
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
    counters_.count("scan_empty", "scan with no usable point at t=" + std::to_string(scan.t_end));
    check_divergence(report, history);
    return report;
  }

  // 2. Deskew through the history (or take the points as measured).
  auto t_stage = Clock::now();
  const StateQuery prior = history.query(scan.t_end);
  const Eigen::Isometry3d T_IL = prior.x.T_IL();
  const bool deskew = config_.preprocess.deskew && deskewer_.prepare(history, scan.t_start, scan.t_end);
  if (config_.preprocess.deskew && !deskew) {
    counters_.count("deskew_without_history", "scan start is not covered by the state history: points used as measured");
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

  // 3. Associate + update at the scan end (the first scan only seeds the map).
  t_stage = Clock::now();
  NavState x = prior.x;
  report.recovery = map_->size() > 0 && needs_recovery(prior.P);
  if (report.recovery) {
    counters_.count("recovery_scans", "uncertain prior at t=" + std::to_string(scan.t_end) +
                                          " (data gap or restart): re-localising against the map");
  }
  if (map_->size() > 0) {
    PointToPlaneModel model(report.recovery ? recovery_measurement_ : config_.measurement, points_L_, *map_,
                            report.recovery ? recovery_associator_ : associator_, constraints_);
    const UpdateResult result = update(model, history, scan.t_end);
    x = history.query(scan.t_end).x;
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

  // 4. Map policy on the world-frame points at the posterior.
  t_stage = Clock::now();
  T_WL_ = x.T_WI() * x.T_IL();
  const Eigen::Isometry3d& T_WL = T_WL_;
  const Eigen::Matrix3f R = T_WL.linear().cast<float>();
  const Eigen::Vector3f t = T_WL.translation().cast<float>();
  points_W_.resize(points_L_.size());
  for (std::size_t i = 0; i < points_L_.size(); ++i) points_W_[i] = R * points_L_[i] + t;
  // The association's nearest-neighbour distances are reused when it ran on this scan's points.
  const bool have_nearest = report.updated && constraints_.nearest_dist2.size() == points_W_.size();
  if (report.recovery && !report.converged) {
    // Not re-localised yet: a misplaced scan in the map would pull the later ones towards it.
    counters_.count("recovery_not_mapped", "re-localisation did not converge at t=" + std::to_string(scan.t_end) +
                                               ": scan not added to the map");
    points_W_.clear();  // nothing accepted to offer (last_world_points)
  } else {
    const MapUpdateStats map_stats =
        map_policy_->apply(points_W_, *map_, have_nearest ? &constraints_.nearest_dist2 : nullptr);
    report.map_inserted = map_stats.inserted;
  }
  report.map_points = map_->size();
  report.ms_map = ms_since(t_stage);
  report.ms_total = ms_since(t0);
  check_divergence(report, history);
  return report;
}

void LidarUpdater::downsample() {
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

void LidarUpdater::order_spatially() {
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

void LidarUpdater::check_divergence(const ScanReport& report, const StateHistory& history) {
  const StateQuery q = history.query(report.t);
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

#include "fuse/estimation/lidar_updater.hpp"
#include "fuse/estimation/zero_velocity.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>

#include <sys/resource.h>
#include <time.h>

#include "fuse/core/logging.hpp"

namespace fuse {

namespace {
/// The prior variance left along a held direction of the extrinsic: the information-form backends
/// need a covariance they can invert, and this keeps the update from moving it (σ 1e-7).
constexpr double kHeldVariance = 1e-14;
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

/// CPU time of the calling thread (ms): what the scan cost whatever else the machine ran.
double thread_cpu_ms() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

/// Page faults the calling thread has taken (first touches of memory, minor and major).
std::uint64_t thread_page_faults() {
  rusage u{};
  ::getrusage(RUSAGE_THREAD, &u);
  return static_cast<std::uint64_t>(u.ru_minflt + u.ru_majflt);
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

/// Raw points per scan the per-scan buffers are sized and faulted in for when the updater is made:
/// one scan of a 64-beam, 1024-column spinning LiDAR. Memory new to the process costs ~13 µs per
/// 4 KiB page on first touch on a virtual machine, which made the first scan of a 32-beam
/// recording 3-4 times the median (docs/performance.md); a larger scan grows them once.
constexpr std::size_t kPresizedScanPoints = 64 * 1024;

/// Sizes v for n elements and writes them, then empties it: its capacity stays, faulted in.
template <typename T>
void presize(std::vector<T>& v, std::size_t n, const T& value) {
  v.assign(n, value);
  v.clear();
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
      excitation_(config.extrinsic_excitation),
      counters_(logger("estimator")) {
  config_.measurement.extrinsic_jacobian = config.estimate_extrinsic;
  recovery_measurement_.extrinsic_jacobian = config.estimate_extrinsic;
  recovery_measurement_.reassociate_iterations = config.recovery.reassociate_iterations;
  // Buffers of the raw scan, and of the points kept (at most all of them on a first scan).
  presize(raw_, kPresizedScanPoints, Eigen::Vector3f::Zero().eval());
  presize(in_range_, kPresizedScanPoints, std::uint32_t{0});
  presize(kept_, kPresizedScanPoints, std::uint32_t{0});
  presize(keyed_, kPresizedScanPoints, std::uint64_t{0});
  presize(sorted_, kPresizedScanPoints, std::uint64_t{0});
  presize(kept_raw_, kPresizedScanPoints, std::uint32_t{0});
  for (auto* points : {&points_L_, &points_W_, &origins_L_, &origins_W_}) {
    presize(*points, kPresizedScanPoints, Eigen::Vector3f::Zero().eval());
  }
  voxel_filter_.reserve(kPresizedScanPoints);
}

namespace {
/// Signed angle (rad, about `up`) from R_a's heading to R_b's: the body axis farthest from `up`
/// (x unless the body is pitched past 45°), projected on the horizontal plane, in each.
double heading_between(const Eigen::Matrix3d& R_a, const Eigen::Matrix3d& R_b, const Eigen::Vector3d& up) {
  const int axis = std::abs(up.dot(R_a.col(0))) < std::abs(up.dot(R_a.col(1))) ? 0 : 1;
  const Eigen::Vector3d a = R_a.col(axis) - up.dot(R_a.col(axis)) * up;
  const Eigen::Vector3d b = R_b.col(axis) - up.dot(R_b.col(axis)) * up;
  return std::atan2(up.dot(a.cross(b)), a.dot(b));
}

/// Largest σ of a 3×3 block of P: the square root of its largest eigenvalue.
double largest_std(const StateCovariance& P, int idx) {
  const Eigen::Matrix3d block = P.block<3, 3>(idx, idx);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(block, Eigen::EigenvaluesOnly);
  return std::sqrt(std::max(es.eigenvalues()(2), 0.0));
}
}  // namespace

void LidarUpdater::hold_still(const LidarScan& scan, StateHistory& history, ScanReport& report) {
  StateQuery q = history.query(scan.t_end);
  if (!q.ok()) return;
  const RestCheck rest = check_rest(imu_window(history, scan.t_start, scan.t_end, config_.divergence.max_imu_gap), q.x,
                                    config_.zero_velocity);
  if (!rest.at_rest) return;
  report.at_rest = true;
  counters_.add("zero_velocity_updates");
  zero_velocity_update(config_.zero_velocity.velocity_std, q.x, q.P);
  history.correct(scan.t_end, q.x, q.P);
}

bool LidarUpdater::needs_recovery(const StateCovariance& P) const {
  if (!config_.recovery.enabled) return false;
  return largest_std(P, Idx::kPos) > config_.recovery.position_std ||
         largest_std(P, Idx::kRot) > config_.recovery.rotation_std;
}

double LidarUpdater::truncated_cost(const NavState& x) const {
  // Σ_j min(r_j², τ²)/σ² over the scan's N kept points; a point without a constraint costs τ²/σ².
  const double tau = config_.recovery.inlier_residual, sigma = recovery_measurement_.point_sigma;
  double cost = 0.0;
  for (const Constraint& c : constraints_.constraints) {
    const double r = point_to_plane_residual(x, c);
    cost += std::min(r * r, tau * tau) / (sigma * sigma);
  }
  const double unconstrained = static_cast<double>(points_L_.size() - constraints_.constraints.size());
  return cost + unconstrained * (tau * tau / (sigma * sigma));
}

double LidarUpdater::match_fit(const NavState& x) const {
  const double tau = config_.recovery.inlier_residual;
  if (constraints_.constraints.empty()) return 0.0;
  double cost = 0.0;  // Σ min(r², τ²)/τ² over the constrained points
  for (const Constraint& c : constraints_.constraints) {
    const double r = point_to_plane_residual(x, c);
    cost += std::min(r * r, tau * tau) / (tau * tau);
  }
  return 1.0 - cost / static_cast<double>(constraints_.constraints.size());
}

double LidarUpdater::fit_of(double cost) const {
  // fit = 1 − cost / (N τ²/σ²): 1 when every point lies on its plane, 0 when none has one within τ.
  const double tau = config_.recovery.inlier_residual, sigma = recovery_measurement_.point_sigma;
  const double n = static_cast<double>(std::max<std::size_t>(points_L_.size(), 1));
  return 1.0 - cost / ((tau * tau / (sigma * sigma)) * n);
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
  const double td_var = prior.P(Idx::kTimeOffset, Idx::kTimeOffset);
  const bool hold_td = td_var > 0.0 && t >= relocalised_at_ &&
                       t - relocalised_at_ < config_.time_offset.hold_after_relocalisation_s;
  if (hold_td) {
    // Just re-localised: the attitude is more confident than right, and the offset's coupling to
    // it (J_r·Δω, imu_propagation.hpp) would take up the difference. Held: row and column out.
    counters_.count("time_offset_held_after_relocalisation",
                    fmt::format("scan at t={:.6f}, {:.2f} s after a re-localisation: the LiDAR-IMU time offset is held "
                                "(estimator.time_offset.hold_after_relocalisation_s = {} s)",
                                t, t - relocalised_at_, config_.time_offset.hold_after_relocalisation_s));
    prior.P.row(Idx::kTimeOffset).setZero();
    prior.P.col(Idx::kTimeOffset).setZero();
  }
  // The extrinsic, when estimated, is held while the motion does not turn about every axis: its
  // rows and columns out of the update, its covariance kept for when the motion does. Turning
  // about one axis a (a vehicle's yaw) shows the LiDAR's tilt against a: with one_axis "tilt"
  // only the rotation about a and the translation are held then (excitation_monitor.hpp).
  const bool hold_ext = config_.estimate_extrinsic && !excitation_.excited();
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  const bool hold_axis =
      hold_ext && config_.extrinsic_excitation.one_axis == ExcitationConfig::OneAxis::kTilt && excitation_.turns_about(axis);
  Eigen::Matrix<double, 6, 6> ext_P, held = Eigen::Matrix<double, 6, 6>::Zero();
  if (hold_ext) {
    counters_.count("extrinsic_held_weak_excitation",
                    fmt::format("scan at t={:.6f}: the extrinsic is held{}, the motion turns too little about its weakest axis "
                                "({:.2f} deg/s RMS over the last {} s; estimator.extrinsic_excitation.min_rate_deg_s = {})",
                                t, hold_axis ? fmt::format(" but for its tilt against the turn axis ({:.2f} {:.2f} {:.2f})",
                                                           axis.x(), axis.y(), axis.z()) : std::string(),
                                excitation_.weakest_rate() * 180.0 / M_PI, config_.extrinsic_excitation.window_s,
                                config_.extrinsic_excitation.min_rate_deg_s));
    ext_P = prior.P.block<6, 6>(Idx::kExtRot, Idx::kExtRot);
    if (hold_axis) {
      counters_.add("extrinsic_held_but_tilt");  // of the scans held, those estimating the tilt (logged above)
      // The rotation error is R_IL·Exp(δθ_IL) (LiDAR side): the axis a is R_ILᵀa there.
      const Eigen::Vector3d a_L = prior.x.R_IL.transpose() * axis;
      held.topLeftCorner<3, 3>() = a_L * a_L.transpose();
      held.bottomRightCorner<3, 3>().setIdentity();
      const Eigen::Matrix<double, 6, 6> keep = Eigen::Matrix<double, 6, 6>::Identity() - held;
      prior.P.middleRows<6>(Idx::kExtRot) = keep * prior.P.middleRows<6>(Idx::kExtRot);
      prior.P.middleCols<6>(Idx::kExtRot) = prior.P.middleCols<6>(Idx::kExtRot) * keep;
      prior.P.block<6, 6>(Idx::kExtRot, Idx::kExtRot) += kHeldVariance * held;
    } else {
      prior.P.middleRows<6>(Idx::kExtRot).setZero();
      prior.P.middleCols<6>(Idx::kExtRot).setZero();
    }
  }
  last_extrinsic_hold_ = !hold_ext ? ExtrinsicHold::kNone : hold_axis ? ExtrinsicHold::kTilt : ExtrinsicHold::kAll;
  UpdateResult result = backend.update(prior.x, prior.P, model);
  if (hold_td) prior.P(Idx::kTimeOffset, Idx::kTimeOffset) = td_var;
  if (hold_axis) {
    prior.P.block<6, 6>(Idx::kExtRot, Idx::kExtRot) += held * ext_P * held - kHeldVariance * held;
  } else if (hold_ext) {
    prior.P.block<6, 6>(Idx::kExtRot, Idx::kExtRot) = ext_P;
  }
  const double bound = config_.time_offset.max_s;
  if (result.updated && std::abs(prior.x.td) > bound) {
    counters_.count("time_offset_at_bound",
                    fmt::format("the LiDAR-IMU time offset estimate {:+.4f} s at t={:.6f} is beyond "
                                "estimator.time_offset.max_s = {} s: held at the bound",
                                prior.x.td, t, bound));
    prior.x.td = std::clamp(prior.x.td, -bound, bound);
  }
  if (result.updated) history.correct(t, prior.x, prior.P);
  return result;
}

ScanReport LidarUpdater::process(const LidarScan& scan, StateHistory& history) {
  const auto t0 = Clock::now();
  const double cpu0 = thread_cpu_ms();
  const std::uint64_t faults0 = thread_page_faults();
  ScanReport report;
  report.t = scan.t_end;
  report.sequence = scan.sequence;
  report.points_in = scan.points.size();
  points_W_.clear();
  points_L_.clear();
  // 1. Range filter and voxel downsampling on the raw (LiDAR frame) points. Points measured before
  //    the end of a data gap in the scan are dropped: nothing measured the motion that would
  //    deskew them (a handheld sensor turns by ~15° in a 0.1 s scan).
  const double measured_since =
      history.measured_since(scan.t_start, scan.t_end, config_.divergence.max_imu_gap) - scan.t_start;
  std::size_t in_gap = 0;
  raw_.clear();
  in_range_.clear();
  const PreprocessConfig::RangeGate gate = config_.preprocess.range_gate();
  for (std::uint32_t i = 0; i < scan.points.size(); ++i) {
    const LidarPoint& p = scan.points[i];
    const Eigen::Vector3f v(p.x, p.y, p.z);
    if (!gate.pass(v)) continue;
    if (p.t_rel < measured_since) {
      ++in_gap;
      continue;
    }
    raw_.push_back(v);
    in_range_.push_back(i);
  }
  if (in_gap > 0) {
    counters_.count("scan_points_in_data_gap", std::to_string(in_gap) + " points of the scan at t=" +
                                                   std::to_string(scan.t_end) + " were measured during a data gap: dropped");
  }
  downsample();
  order_spatially();
  report.points_kept = kept_raw_.size();
  if (kept_raw_.empty()) {
    counters_.count("scan_empty", "scan with no usable point at t=" + std::to_string(scan.t_end));
    check_divergence(report, history);
    return report;
  }

  // 2. At rest (zero_velocity.hpp): v = 0 is measured first, so the deskew and the prior below
  //    use it. Then deskew through the history (or take the points as measured).
  auto t_stage = Clock::now();
  if (config_.zero_velocity.enabled) hold_still(scan, history, report);
  const StateQuery prior = history.query(scan.t_end);
  const Eigen::Isometry3d T_IL = prior.x.T_IL();
  const bool deskew = config_.preprocess.deskew && deskewer_.prepare(history, scan.t_start, scan.t_end);
  if (config_.preprocess.deskew && !deskew) {
    counters_.count("deskew_without_history", "scan start is not covered by the state history: points used as measured");
  }
  // The rays' origins only for a map policy that carves with them (they cost a second rotation
  // per point); origins_L_ stays empty otherwise.
  const bool rays = map_policy_->uses_rays();
  origins_L_.clear();
  if (deskew) {
    deskewer_.apply(scan, kept_raw_, T_IL, points_L_, rays ? &origins_L_ : nullptr);
  } else {
    if (rays) origins_L_.assign(kept_raw_.size(), Eigen::Vector3f::Zero());
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
  report.time_offset = prior.x.td;
  report.prior_position_std = largest_std(prior.P, Idx::kPos);
  report.prior_rotation_std = largest_std(prior.P, Idx::kRot);
  report.recovery = map_->size() > 0 && needs_recovery(prior.P);
  if (report.recovery) {
    counters_.count("recovery_scans", fmt::format("uncertain prior at t={:.6f} (σ position {:.3f} m, rotation {:.3f} rad: "
                                                  "a data gap or a restart): re-localising against the map",
                                                  scan.t_end, std::sqrt(prior.P.block<3, 3>(Idx::kPos, Idx::kPos).trace()),
                                                  std::sqrt(prior.P.block<3, 3>(Idx::kRot, Idx::kRot).trace())));
  }
  const std::size_t in_range = raw_.size() + in_gap;
  const bool sliver = report.recovery && in_gap > 0 &&
                      static_cast<double>(raw_.size()) < config_.recovery.min_measured_fraction * static_cast<double>(in_range);
  if (sliver) {
    counters_.count("recovery_scan_mostly_in_gap",
                    fmt::format("scan at t={:.6f} not re-localised: only {} of its {} points were measured after the data "
                                "gap (recovery.min_measured_fraction {:.2f}); the prior stays, the next scan searches",
                                scan.t_end, raw_.size(), in_range, config_.recovery.min_measured_fraction));
  }
  if (map_->size() > 0 && !sliver && !report.recovery && map_policy_->marks_moving()) screen_moving(prior.x, report);
  if (map_->size() > 0 && !sliver) {
    UpdateResult result;
    if (report.recovery) {
      result = relocalise(history, scan.t_end, report);
    } else {
      PointToPlaneModel model(config_.measurement, points_L_, *map_, associator_, constraints_);
      result = update(model, history, scan.t_end);
      report.ms_association = model.association_ms();
      report.map_searches = model.searches();
    }
    x = history.query(scan.t_end).x;
    report.time_offset = x.td;
    if (!report.recovery && result.updated) report.fit = fit_of(truncated_cost(x));  // relocalise sets its own
    if (result.updated) report.match_fit = match_fit(x);
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
  }
  report.ms_update = ms_since(t_stage) - report.ms_association;

  // 4. Map policy on the world-frame points at the posterior.
  t_stage = Clock::now();
  T_WL_ = x.T_WI() * x.T_IL();
  report.extrinsic_rotation = so3::Log(x.R_IL);
  report.extrinsic_translation = x.p_IL;
  report.extrinsic_held = report.updated ? last_extrinsic_hold_ : ExtrinsicHold::kNone;
  if (report.updated && config_.estimate_extrinsic) excitation_.add(scan.t_end, x.R);
  const Eigen::Isometry3d& T_WL = T_WL_;
  const Eigen::Matrix3f R = T_WL.linear().cast<float>();
  const Eigen::Vector3f t = T_WL.translation().cast<float>();
  points_W_.resize(points_L_.size());
  for (std::size_t i = 0; i < points_L_.size(); ++i) points_W_[i] = R * points_L_[i] + t;
  // The association's nearest-neighbour distances are reused when it ran on this scan's points.
  const bool have_nearest = report.updated && constraints_.nearest_dist2.size() == points_W_.size();
  report.map_held = holds_map(report, x);
  if (report.recovery && (!report.updated || !report.converged || report.fit < config_.recovery.min_fit)) {
    // Not re-localised yet: a misplaced scan in the map would pull the later ones towards it.
    const char* why = !report.updated ? "was not taken" : report.converged ? "fits poorly" : "did not converge";
    counters_.count("recovery_not_mapped", fmt::format("re-localisation at t={:.6f} {} (fit {:.3f}): scan not added to the map",
                                                       scan.t_end, why, report.fit));
    points_W_.clear();  // nothing accepted to offer (last_world_points)
  } else {
    if (report.map_held) {
      // Held: only the points within recovery.map_hold_radius of the sensor are offered. They keep
      // the map dense where the scan is (later scans need them), and a small pose error moves
      // them little; the far ones, where the same error grows with the range, wait.
      const auto r2 = static_cast<float>(config_.recovery.map_hold_radius * config_.recovery.map_hold_radius);
      std::size_t kept = 0;
      for (std::size_t i = 0; i < points_W_.size(); ++i) {
        if (points_L_[i].squaredNorm() < r2) points_W_[kept++] = points_W_[i];
      }
      points_W_.resize(kept);
    }
    // The scan's rays carve the map (a map policy's free-space carving) only from a pose the
    // update has just confirmed: a scan misplaced would carve through walls. (No origins: the
    // policy does not carve.)
    const bool trusted = report.updated && report.converged && !report.recovery && !report.map_held &&
                         !origins_L_.empty();
    if (trusted) {
      origins_W_.resize(origins_L_.size());
      for (std::size_t i = 0; i < origins_L_.size(); ++i) origins_W_[i] = R * origins_L_[i] + t;
    }
    const MapUpdateStats map_stats =
        map_policy_->apply(scan.t_end, points_W_, *map_, have_nearest && !report.map_held ? &constraints_.nearest_dist2 : nullptr,
                           nullptr, trusted ? &origins_W_ : nullptr);
    report.map_inserted = map_stats.inserted;
    report.map_carved = map_stats.carved;
    report.map_pending = map_stats.pending;
    if (report.updated && map_stats.inserted > 0 && !points_W_.empty()) {
      // Map-frame drift: the filter's covariance P is that of the pose relative to the map, whose
      // points are taken as exact. The points this scan adds sit where its posterior put them, so
      // new space inherits the posterior's error: var(map_new) = var(map_old) + P_pose. A scan of
      // which a fraction f is new adds f·P_pose to the map frame's uncertainty (a random walk over
      // explored space; revisited space adds nothing). Reported beside P to planners, never fed
      // back into the filter.
      const StateQuery post = history.query(scan.t_end);
      const double f = static_cast<double>(map_stats.inserted) / static_cast<double>(points_W_.size());
      report.map_drift.topLeftCorner<3, 3>() = f * post.P.block<3, 3>(Idx::kPos, Idx::kPos);
      report.map_drift.bottomRightCorner<3, 3>() =
          f * post.x.R * post.P.block<3, 3>(Idx::kRot, Idx::kRot) * post.x.R.transpose();
    }
  }
  report.map_points = map_->size();
  report.ms_map = ms_since(t_stage);
  report.ms_total = ms_since(t0);
  report.ms_cpu = thread_cpu_ms() - cpu0;
  report.page_faults = thread_page_faults() - faults0;
  check_divergence(report, history);
  return report;
}

bool LidarUpdater::holds_map(const ScanReport& report, const NavState& x) {
  // recovery.map_hold_distance: from a re-localised scan until the vehicle has moved that far from
  // it, the map is extended only near the sensor; the estimate settles against the map as it was.
  const double hold = config_.recovery.map_hold_distance;
  if (hold <= 0.0) return false;
  if (report.recovery && report.updated) {
    if (!hold_from_) {
      counters_.count("map_hold", fmt::format("re-localised at t={:.6f}: for the next {} m the map is extended only within {} m "
                                              "of the sensor (estimator.recovery.map_hold_distance, map_hold_radius)",
                                              report.t, hold, config_.recovery.map_hold_radius));
    }
    hold_from_ = x.p;
    return true;
  }
  if (!hold_from_) return false;
  if ((x.p - *hold_from_).norm() < hold) return true;
  hold_from_.reset();
  return false;
}

std::optional<LidarUpdater::CoastedGap> LidarUpdater::coasted_gap(const StateHistory& history, double t) {
  // The latest run of coasting entries after the last correction: the gap the prior crosses.
  const auto entries = history.entries_between(history.last_correction_time(), t);
  std::optional<CoastedGap> gap;
  for (std::size_t i = entries.size(); i-- > 0;) {
    if (entries[i]->coasting) {
      // The step from a coasting entry ends at the next entry (or, still coasting, at this one).
      if (!gap) gap = CoastedGap{entries[i]->x.p, i + 1 < entries.size() ? entries[i + 1]->x.p : entries[i]->x.p};
      gap->p_start = entries[i]->x.p;
    } else if (gap) {
      break;
    }
  }
  return gap;
}

NavState LidarUpdater::turned(const NavState& prior, const std::optional<CoastedGap>& gap, double psi, const Eigen::Vector3d& up) {
  // The prior coasted a gap as if the vehicle kept its rotation rate; hypothesis ψ adds a turn by ψ
  // about the vertical, spread evenly over the gap. A constant-rate turn moves along an arc whose
  // chord is the coasted displacement c turned by ψ/2 and shortened by sinc(ψ/2):
  //   p_end' = p_start + Exp(ψ/2·u)·c·sin(ψ/2)/(ψ/2),  p' = p_end' + Exp(ψ u)(p̂ − p_end),
  //   v' = Exp(ψ u) v̂,  R' = Exp(ψ u) R̂.
  // Without a coasted gap (a restart's prior) the turn is about the prior's position.
  NavState x = prior;
  const Eigen::Matrix3d turn = so3::Exp(psi * up);
  x.R = so3::Normalize(turn * prior.R);
  x.v = turn * prior.v;
  if (gap && psi != 0.0) {
    const double half = 0.5 * psi;
    const Eigen::Vector3d end = gap->p_start + so3::Exp(half * up) * (gap->p_end - gap->p_start) * (std::sin(half) / half);
    x.p = end + turn * (prior.p - gap->p_end);
  }
  return x;
}

// Heading search: the recovery update (no screening, recovery caps) from K priors
//   x_k = turned(x̂, ψ_k): R_WI,k = Exp(ψ_k u) R̂_WI,  ψ_k = 2πk/K,  u = −ĝ/|ĝ| (up),
// its velocity turned alike and, after a coasted gap, its position moved to the end of the arc
// that turn would have followed through the gap (turned, above),
// each scored by the negative log-posterior of its result x_k⁺ under a truncated-Gaussian point
// model (σ = measurement.point_sigma, τ = recovery.inlier_residual) and the prior's pose block:
//   E_k = Σ_{j=1..N} min(r_j², τ²)/σ² + ‖x_k⁺ ⊟ x̂‖²_{P_pose}
// over the N scan points (a point without a constraint costs τ²/σ²). The prior's own result (k = 0)
// stands unless a converged x_k⁺ has E_k < E_0 − m·N·τ²/σ² (m = recovery.heading_margin), so that a
// symmetric place, which fits its mirror image almost as well, keeps the prior's heading.
// Turning the whole history about the vertical leaves the deskewed points unchanged, so the
// hypotheses share them. Only a prior whose heading is uncertain on the hypotheses' scale
// searches: 3σ_ψ at least half their spacing, σ_ψ ≥ π/(3K) (5° for K = 12). A narrower prior
// cannot have its heading between two hypotheses, and one run from it converges within its
// basin; searching anyway cost every scan of a coasted stretch (σ_ψ = gap_gyro_std · 0.1 s) a
// dozen updates, too slow for fuse-update to catch up on the scans held through a restart.
UpdateResult LidarUpdater::relocalise(StateHistory& history, double t, ScanReport& report) {
  const StateQuery prior = history.query(t);
  const Eigen::Vector3d up = -prior.x.g.normalized();
  // Only a prior whose heading is uncertain searches: σ_ψ² = (R̂ᵀu)ᵀ P_θθ (R̂ᵀu) (body-frame δθ).
  const Eigen::Vector3d up_I = prior.x.R.transpose() * up;
  const double heading_std = std::sqrt(std::max(up_I.dot(prior.P.block<3, 3>(Idx::kRot, Idx::kRot) * up_I), 0.0));
  const int hypotheses = config_.recovery.heading_hypotheses;
  const int K = hypotheses > 1 && 3.0 * heading_std >= M_PI / hypotheses ? hypotheses : 1;
  const double tau = config_.recovery.inlier_residual, sigma = recovery_measurement_.point_sigma;
  const double outlier_cost = tau * tau / (sigma * sigma);
  const double margin = config_.recovery.heading_margin * static_cast<double>(points_L_.size()) * outlier_cost;
  const Eigen::Matrix<double, 6, 6> pose_information = prior.P.topLeftCorner<6, 6>().inverse();
  auto log_posterior_cost = [&](const NavState& x, double& fit) {
    const double points_cost = truncated_cost(x);
    fit = fit_of(points_cost);
    Eigen::Matrix<double, 6, 1> d;
    d << x.p - prior.x.p, so3::Log(prior.x.R.transpose() * x.R);
    return points_cost + d.dot(pose_information * d);
  };
  UpdateResult best;
  NavState best_x = prior.x;
  StateCovariance best_P = prior.P;
  double best_cost = 0.0, prior_cost = 0.0;
  double heading_change = 0.0;  // rad: the kept result's start heading off the prior's
  report.ms_association = 0.0;
  const std::optional<CoastedGap> gap =
      config_.recovery.turn_through_gap ? coasted_gap(history, t) : std::optional<CoastedGap>{};
  struct Converged {
    Eigen::Matrix3d R;
    double fit;
  };
  std::vector<Converged> converged;  // every converged result, for the ambiguity check below
  for (int k = 0; k < K; ++k) {
    const double psi = 2.0 * M_PI * k / K;
    NavState x = turned(prior.x, gap, psi > M_PI ? psi - 2.0 * M_PI : psi, up);
    StateCovariance P = prior.P;
    // A re-localisation does not move the time offset or the extrinsic: what it corrects is the
    // gap's, not timing or calibration.
    P.row(Idx::kTimeOffset).setZero();
    P.col(Idx::kTimeOffset).setZero();
    P.middleRows<6>(Idx::kExtRot).setZero();
    P.middleCols<6>(Idx::kExtRot).setZero();
    PointToPlaneModel model(recovery_measurement_, points_L_, *map_, recovery_associator_, constraints_);
    const UpdateResult result = recovery_backend_->update(x, P, model);
    report.ms_association += model.association_ms();
    report.map_searches += model.searches();
    double fit = 0.0;
    const double cost = result.updated ? log_posterior_cost(x, fit) : std::numeric_limits<double>::infinity();
    logger("estimator")->debug("re-localisation at t={:.6f} from heading {:+.0f} deg: fit {:.3f}, cost {:.1f}, {} iterations{}",
                               t, psi * 180.0 / M_PI, fit, cost, result.iterations, result.converged ? "" : " (not converged)");
    if (k == 0) prior_cost = cost;
    if (result.updated && result.converged) converged.push_back({x.R, fit});
    const bool better = k == 0 || (result.updated && result.converged && cost < prior_cost - margin && cost < best_cost);
    if (!better) continue;
    best = result;
    best_x = x;
    best_P = P;
    best_cost = cost;
    report.fit = fit;
    heading_change = psi > M_PI ? psi - 2.0 * M_PI : psi;
    std::swap(best_constraints_, constraints_);
  }
  std::swap(best_constraints_, constraints_);  // the kept hypothesis' constraints (map policy, report)
  if (best.updated && report.fit < config_.recovery.commit_fit) {
    counters_.count("recovery_not_committed", fmt::format("re-localisation at t={:.6f} fits too poorly to be taken (fit {:.3f} < "
                                                          "recovery.commit_fit {:.2f}): the prior stays, the next scan searches again",
                                                          t, report.fit, config_.recovery.commit_fit));
    best.updated = false;
    return best;
  }
  const double angle = config_.recovery.ambiguity_angle;
  if (best.updated && std::abs(heading_between(prior.x.R, best_x.R, up)) > angle) {
    // Ambiguous: the kept result turned away from the prior's heading while a result at another
    // heading fits nearly as well. (A mirror image fitting as well as a result that kept the
    // prior's heading is the normal case in a corridor: the prior decides, as it should.)
    for (const Converged& c : converged) {
      const double dpsi = heading_between(best_x.R, c.R, up);
      if (std::abs(dpsi) <= angle || c.fit < report.fit - config_.recovery.ambiguity_fit) continue;
      if (report.ambiguous && c.fit <= report.rival_fit) continue;
      report.ambiguous = true;
      report.rival_fit = c.fit;
      report.rival_heading = dpsi;
    }
    if (report.ambiguous) {
      counters_.count("recovery_ambiguous",
                      fmt::format("re-localisation at t={:.6f} is ambiguous: it turned {:+.0f} deg from the prior's heading to a "
                                  "fit of {:.3f}, and a result {:+.0f} deg from it fits {:.3f} "
                                  "(recovery.ambiguity_fit {:.2f}): the heading may be wrong",
                                  t, heading_between(prior.x.R, best_x.R, up) * 180.0 / M_PI, report.fit,
                                  report.rival_heading * 180.0 / M_PI, report.rival_fit, config_.recovery.ambiguity_fit));
    }
  }
  if (heading_change != 0.0) {
    counters_.count("recovery_heading_changed", "re-localisation at t=" + std::to_string(t) + " started from a heading " +
                                                    std::to_string(heading_change * 180.0 / M_PI) +
                                                    " deg off the prior's: a better fit");
  }
  best_P(Idx::kTimeOffset, Idx::kTimeOffset) = prior.P(Idx::kTimeOffset, Idx::kTimeOffset);
  best_P.block<6, 6>(Idx::kExtRot, Idx::kExtRot) = prior.P.block<6, 6>(Idx::kExtRot, Idx::kExtRot);
  if (best.updated) {
    history.correct(t, best_x, best_P);
    relocalised_at_ = t;
  }
  return best;
}

void LidarUpdater::screen_moving(const NavState& prior, ScanReport& report) {
  // Placed by the prior: a few centimetres off at most against carve_radius.
  const Eigen::Isometry3d T_WL = prior.T_WI() * prior.T_IL();
  const Eigen::Matrix3f R = T_WL.linear().cast<float>();
  const Eigen::Vector3f t = T_WL.translation().cast<float>();
  points_W_.resize(points_L_.size());
  for (std::size_t i = 0; i < points_L_.size(); ++i) points_W_[i] = R * points_L_[i] + t;
  report.moving_screened = map_policy_->mark_moving(report.t, points_W_, *map_, moving_);
  if (report.moving_screened == 0) return;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < points_L_.size(); ++i) {
    if (moving_[i] != 0) continue;
    points_L_[kept] = points_L_[i];
    if (!origins_L_.empty()) origins_L_[kept] = origins_L_[i];
    kept_raw_[kept] = kept_raw_[i];
    ++kept;
  }
  points_L_.resize(kept);
  if (!origins_L_.empty()) origins_L_.resize(kept);
  kept_raw_.resize(kept);
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
    // The 30-bit Morton code above the point's index.
    const std::uint64_t code = spread(cx) | (spread(cy) << 1) | (spread(cz) << 2);
    keyed_[i] = code << 32 | in_range_[kept_[i]];
  }
  // Stable LSD radix sort on the code, three 10-bit digits: the points come in input order, so
  // equal codes stay ordered by index, as a full sort of the keys would leave them (a comparison
  // sort took four times as long).
  constexpr int kDigitBits = 10;
  constexpr std::size_t kBuckets = std::size_t{1} << kDigitBits;
  sorted_.resize(keyed_.size());
  for (int shift = 32; shift < 32 + 3 * kDigitBits; shift += kDigitBits) {
    std::array<std::uint32_t, kBuckets> start{};
    for (const std::uint64_t k : keyed_) ++start[(k >> shift) & (kBuckets - 1)];
    std::uint32_t sum = 0;
    for (std::uint32_t& c : start) sum += std::exchange(c, sum);
    for (const std::uint64_t k : keyed_) sorted_[start[(k >> shift) & (kBuckets - 1)]++] = k;
    keyed_.swap(sorted_);
  }
  kept_raw_.resize(keyed_.size());
  for (std::size_t i = 0; i < keyed_.size(); ++i) kept_raw_[i] = static_cast<std::uint32_t>(keyed_[i]);
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

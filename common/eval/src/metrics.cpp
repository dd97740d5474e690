// APE / RPE / drift metrics with evo's definitions (evo/core/metrics.py, filters.py).
#include "fuse/eval/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace fuse::eval {
namespace {

constexpr double kRadToDeg = 180.0 / EIGEN_PI;

void require_associated(const Trajectory& reference, const Trajectory& estimate) {
  if (reference.size() != estimate.size()) {
    throw std::invalid_argument("metrics need associated trajectories of equal length (" +
                                std::to_string(reference.size()) + " vs " + std::to_string(estimate.size()) + ")");
  }
}

Eigen::Isometry3d to_isometry(const StampedPose& pose) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = pose.q.normalized().toRotationMatrix();
  T.translation() = pose.p;
  return T;
}

/// Angle of a rotation in degrees (the norm of its SO(3) logarithm).
double angle_deg(const Eigen::Matrix3d& R) { return Eigen::AngleAxisd(R).angle() * kRadToDeg; }

/// E_ij = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j): the relative-pose error of one pair.
Eigen::Isometry3d relative_error(const Trajectory& reference, const Trajectory& estimate, std::size_t i, std::size_t j) {
  if (i >= reference.size() || j >= reference.size()) throw std::invalid_argument("RPE pair index out of range");
  const Eigen::Isometry3d Q_rel = to_isometry(reference[i]).inverse() * to_isometry(reference[j]);
  const Eigen::Isometry3d P_rel = to_isometry(estimate[i]).inverse() * to_isometry(estimate[j]);
  return Q_rel.inverse() * P_rel;
}

/// numpy.median: the middle value, or the mean of the two middle values for an even count.
double median(std::vector<double> values) {
  const std::size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(mid), values.end());
  const double upper = values[mid];
  if (values.size() % 2 == 1) return upper;
  const double lower = *std::max_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(mid));
  return 0.5 * (lower + upper);
}

}  // namespace

ErrorStatistics compute_statistics(const std::vector<double>& errors) {
  if (errors.empty()) throw std::invalid_argument("statistics of an empty error array");
  const double n = static_cast<double>(errors.size());
  ErrorStatistics s;
  s.count = errors.size();
  s.sse = std::inner_product(errors.begin(), errors.end(), errors.begin(), 0.0);
  s.rmse = std::sqrt(s.sse / n);
  s.mean = std::accumulate(errors.begin(), errors.end(), 0.0) / n;
  double squared_deviation = 0.0;
  for (const double e : errors) squared_deviation += (e - s.mean) * (e - s.mean);
  s.std = std::sqrt(squared_deviation / n);  // population std, numpy ddof = 0
  s.median = median(errors);
  const auto [lo, hi] = std::minmax_element(errors.begin(), errors.end());
  s.min = *lo;
  s.max = *hi;
  return s;
}

std::vector<double> ape_translation_errors(const Trajectory& reference, const Trajectory& estimate) {
  require_associated(reference, estimate);
  std::vector<double> errors(reference.size());
  for (std::size_t i = 0; i < reference.size(); ++i) errors[i] = (estimate[i].p - reference[i].p).norm();
  return errors;
}

std::vector<double> ape_rotation_errors_deg(const Trajectory& reference, const Trajectory& estimate) {
  require_associated(reference, estimate);
  std::vector<double> errors(reference.size());
  for (std::size_t i = 0; i < reference.size(); ++i) {
    errors[i] = angle_deg(reference[i].q.normalized().toRotationMatrix().transpose() *
                          estimate[i].q.normalized().toRotationMatrix());
  }
  return errors;
}

IdPairs pairs_by_path(const Trajectory& trajectory, double delta_m) {
  if (!(delta_m > 0.0) || !std::isfinite(delta_m)) {
    throw std::invalid_argument("RPE delta must be a finite number of metres > 0, got " + std::to_string(delta_m));
  }
  std::vector<std::size_t> ids;
  double current_path = 0.0;
  for (std::size_t i = 1; i < trajectory.size(); ++i) {
    current_path += (trajectory[i].p - trajectory[i - 1].p).norm();
    if (current_path >= delta_m) {
      ids.push_back(i);
      current_path = 0.0;
    }
  }
  IdPairs pairs;
  for (std::size_t k = 1; k < ids.size(); ++k) pairs.emplace_back(ids[k - 1], ids[k]);
  return pairs;
}

std::vector<double> rpe_translation_errors(const Trajectory& reference, const Trajectory& estimate,
                                           const IdPairs& pairs) {
  require_associated(reference, estimate);
  std::vector<double> errors;
  errors.reserve(pairs.size());
  for (const auto& [i, j] : pairs) errors.push_back(relative_error(reference, estimate, i, j).translation().norm());
  return errors;
}

std::vector<double> rpe_rotation_errors_deg(const Trajectory& reference, const Trajectory& estimate,
                                            const IdPairs& pairs) {
  require_associated(reference, estimate);
  std::vector<double> errors;
  errors.reserve(pairs.size());
  for (const auto& [i, j] : pairs) errors.push_back(angle_deg(relative_error(reference, estimate, i, j).linear()));
  return errors;
}

double path_length(const Trajectory& trajectory) {
  double length = 0.0;
  for (std::size_t i = 1; i < trajectory.size(); ++i) length += (trajectory[i].p - trajectory[i - 1].p).norm();
  return length;
}

double end_to_end_distance(const Trajectory& trajectory) {
  if (trajectory.empty()) return 0.0;
  return (trajectory.back().p - trajectory.front().p).norm();
}

TerminalDrift terminal_drift(const Trajectory& reference, const Trajectory& estimate) {
  require_associated(reference, estimate);
  if (reference.empty()) throw std::invalid_argument("terminal drift of empty trajectories");
  // A = T_ref,0 T_est,0⁻¹ puts the first estimated pose on the first reference pose.
  const Eigen::Isometry3d A = to_isometry(reference.front()) * to_isometry(estimate.front()).inverse();
  const Eigen::Isometry3d est_last = A * to_isometry(estimate.back());
  const Eigen::Isometry3d ref_last = to_isometry(reference.back());

  TerminalDrift drift;
  drift.translation_m = est_last.translation() - ref_last.translation();
  drift.translation_norm_m = drift.translation_m.norm();
  const Eigen::Matrix3d R_err = est_last.linear() * ref_last.linear().transpose();
  // ZYX Euler angles of R_err = Rz(yaw) Ry(pitch) Rx(roll).
  drift.yaw_deg = std::atan2(R_err(1, 0), R_err(0, 0)) * kRadToDeg;
  drift.pitch_deg = std::asin(std::clamp(-R_err(2, 0), -1.0, 1.0)) * kRadToDeg;
  drift.roll_deg = std::atan2(R_err(2, 1), R_err(2, 2)) * kRadToDeg;
  drift.rotation_angle_deg = Eigen::AngleAxisd(R_err).angle() * kRadToDeg;
  return drift;
}

}  // namespace fuse::eval

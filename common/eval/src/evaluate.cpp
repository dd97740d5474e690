// Full evaluation: associate, align (ATE), RPE along the reference path, terminal drift.
#include "fuse/eval/evaluate.hpp"

#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "fuse/core/logging.hpp"

namespace fuse::eval {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr int kOutputPrecision = 6;  // decimals in text and JSON output (µm, µdeg)
constexpr double kPercent = 100.0;

/// Poses from the API (not only from checked files) must be finite with non-zero quaternions.
void check_finite(const Trajectory& trajectory, const std::string& name) {
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const StampedPose& pose = trajectory[i];
    if (!std::isfinite(pose.t) || !pose.p.allFinite() || !pose.q.coeffs().allFinite() || pose.q.norm() == 0.0) {
      throw std::invalid_argument(name + " pose " + std::to_string(i) + " has a non-finite value or zero quaternion");
    }
  }
}

AssociatedTrajectories associate(const Trajectory& reference, const Trajectory& estimate,
                                 const EvaluationConfig& config) {
  return config.association == AssociationMode::kIndex
             ? associate_by_index(reference, estimate)
             : associate_by_time(reference, estimate, config.max_time_difference);
}

/// Formats one value: integers without decimals, NaN / inf as `missing`.
std::string format_value(double value, const std::string& missing) {
  if (!std::isfinite(value)) return missing;
  std::ostringstream out;
  if (value == std::floor(value) && std::abs(value) < 1e15) {
    out << static_cast<long long>(value);
  } else {
    out << std::fixed << std::setprecision(kOutputPrecision) << value;
  }
  return out.str();
}

}  // namespace

void EvaluationConfig::validate() const {
  if (!(max_time_difference >= 0.0) || !std::isfinite(max_time_difference)) {
    throw std::invalid_argument("max_time_difference must be a finite number >= 0 s");
  }
  if (!(rpe_delta_m > 0.0) || !std::isfinite(rpe_delta_m)) {
    throw std::invalid_argument("rpe_delta_m must be a finite number > 0 m");
  }
}

EvaluationResult evaluate(const Trajectory& reference, const Trajectory& estimate, const EvaluationConfig& config,
                          ErrorSeries* series) {
  config.validate();
  check_finite(reference, "reference");
  check_finite(estimate, "estimate");
  const AssociatedTrajectories matched = associate(reference, estimate, config);
  const std::size_t n = matched.reference.size();
  if (n < kMinMatchedPoses) {
    throw std::runtime_error("only " + std::to_string(n) + " matched poses; at least " +
                             std::to_string(kMinMatchedPoses) + " are needed");
  }

  EvaluationResult r;
  r.matched_poses = n;
  r.reference_poses = reference.size();
  r.estimate_poses = estimate.size();

  // ATE: evo_ape translation part after Umeyama alignment of the matched positions.
  try {
    r.alignment = align(matched.reference, matched.estimate, config.alignment);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(std::string("alignment failed: ") + e.what());
  }
  const Trajectory aligned = transform(matched.estimate, r.alignment);
  std::vector<double> ape_m = ape_translation_errors(matched.reference, aligned);
  std::vector<double> ape_deg = ape_rotation_errors_deg(matched.reference, aligned);
  r.ate = compute_statistics(ape_m);
  r.ate_rotation_deg = compute_statistics(ape_deg);

  // RPE: evo_rpe translation and rotation parts, consecutive pairs every delta metres of
  // reference path, unaligned.
  IdPairs pairs = pairs_by_path(matched.reference, config.rpe_delta_m);
  std::vector<double> rpe_m, rpe_deg;
  if (pairs.empty()) {
    logger("eval")->warn("RPE: the reference path ({:.3f} m) is too short for delta {} m; no RPE",
                         path_length(matched.reference), config.rpe_delta_m);
  } else {
    rpe_m = rpe_translation_errors(matched.reference, matched.estimate, pairs);
    rpe_deg = rpe_rotation_errors_deg(matched.reference, matched.estimate, pairs);
    r.rpe = compute_statistics(rpe_m);
    r.rpe_rotation_deg = compute_statistics(rpe_deg);
  }

  r.end_to_end_m = end_to_end_distance(estimate);
  r.reference_end_to_end_m = end_to_end_distance(reference);
  r.drift = terminal_drift(matched.reference, matched.estimate);
  r.path_length_m = path_length(matched.reference);
  r.estimate_path_length_m = path_length(matched.estimate);
  r.drift_percent = r.path_length_m > 0.0 ? r.drift.translation_norm_m / r.path_length_m * kPercent : kNaN;
  if (series != nullptr) {
    series->distance_m.assign(n, 0.0);
    for (std::size_t i = 1; i < n; ++i) {
      series->distance_m[i] = series->distance_m[i - 1] + (matched.reference[i].p - matched.reference[i - 1].p).norm();
    }
    series->reference = matched.reference;
    series->aligned = aligned;
    series->ape_m = std::move(ape_m);
    series->ape_deg = std::move(ape_deg);
    series->rpe_pairs = std::move(pairs);
    series->rpe_m = std::move(rpe_m);
    series->rpe_deg = std::move(rpe_deg);
  }
  return r;
}

std::vector<std::pair<std::string, double>> result_fields(const EvaluationResult& r) {
  const auto rpe = [&r](double ErrorStatistics::*field) { return r.rpe ? (*r.rpe).*field : kNaN; };
  return {
      {"ate_rmse_m", r.ate.rmse},
      {"ate_mean_m", r.ate.mean},
      {"ate_median_m", r.ate.median},
      {"ate_std_m", r.ate.std},
      {"ate_min_m", r.ate.min},
      {"ate_max_m", r.ate.max},
      {"rpe_trans_rmse_m", rpe(&ErrorStatistics::rmse)},
      {"rpe_trans_mean_m", rpe(&ErrorStatistics::mean)},
      {"rpe_trans_median_m", rpe(&ErrorStatistics::median)},
      {"rpe_trans_std_m", rpe(&ErrorStatistics::std)},
      {"rpe_trans_max_m", rpe(&ErrorStatistics::max)},
      {"rpe_pairs", r.rpe ? static_cast<double>(r.rpe->count) : 0.0},
      {"ate_rot_rmse_deg", r.ate_rotation_deg.rmse},
      {"ate_rot_max_deg", r.ate_rotation_deg.max},
      {"rpe_rot_rmse_deg", r.rpe_rotation_deg ? r.rpe_rotation_deg->rmse : kNaN},
      {"rpe_rot_max_deg", r.rpe_rotation_deg ? r.rpe_rotation_deg->max : kNaN},
      {"end_to_end_m", r.end_to_end_m},
      {"gt_end_to_end_m", r.reference_end_to_end_m},
      {"drift_x_m", r.drift.translation_m.x()},
      {"drift_y_m", r.drift.translation_m.y()},
      {"drift_z_m", r.drift.translation_m.z()},
      {"drift_trans_m", r.drift.translation_norm_m},
      {"drift_yaw_deg", r.drift.yaw_deg},
      {"drift_pitch_deg", r.drift.pitch_deg},
      {"drift_roll_deg", r.drift.roll_deg},
      {"drift_rot_deg", r.drift.rotation_angle_deg},
      {"drift_percent", r.drift_percent},
      {"path_length_m", r.path_length_m},
      {"est_path_length_m", r.estimate_path_length_m},
      {"alignment_scale", r.alignment.scale},
      {"matched_poses", static_cast<double>(r.matched_poses)},
      {"gt_poses", static_cast<double>(r.reference_poses)},
      {"est_poses", static_cast<double>(r.estimate_poses)},
  };
}

std::string format_text(const EvaluationResult& result) {
  std::ostringstream out;
  for (const auto& [name, value] : result_fields(result)) out << name << ": " << format_value(value, "nan") << '\n';
  return out.str();
}

std::string format_json(const EvaluationResult& result) {
  std::ostringstream out;
  out << '{';
  bool first = true;
  for (const auto& [name, value] : result_fields(result)) {
    out << (first ? "" : ", ") << '"' << name << "\": " << format_value(value, "null");
    first = false;
  }
  out << "}\n";
  return out.str();
}

}  // namespace fuse::eval

// One call that evaluates an estimate against a reference: association, alignment, ATE, RPE,
// terminal drift (docs/evaluation-metrics.md). Used by fuse-eval and the runner.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fuse/eval/alignment.hpp"
#include "fuse/eval/association.hpp"
#include "fuse/eval/metrics.hpp"
#include "fuse/eval/trajectory.hpp"

namespace fuse::eval {

/// How estimate poses are matched to reference poses.
enum class AssociationMode {
  kTimestamp,  ///< nearest timestamp within max_time_difference (TUM files)
  kIndex,      ///< pose i with pose i (KITTI files)
};

/// evo_rpe --delta default used by FUSE (metres of reference path between pair poses).
inline constexpr double kDefaultRpeDeltaM = 1.0;

struct EvaluationConfig {
  AssociationMode association = AssociationMode::kTimestamp;
  double max_time_difference = kDefaultMaxTimeDifference;  ///< s, evo --t_max_diff
  AlignmentMode alignment = AlignmentMode::kSE3;           ///< for the ATE (evo_ape -a)
  double rpe_delta_m = kDefaultRpeDeltaM;                  ///< evo_rpe --delta D --delta_unit m

  /// Throws std::invalid_argument naming the first invalid field.
  void validate() const;
};

struct EvaluationResult {
  std::size_t matched_poses = 0;
  std::size_t reference_poses = 0;
  std::size_t estimate_poses = 0;
  Similarity3 alignment;     ///< estimate -> reference transform used for the ATE
  ErrorStatistics ate;       ///< APE translation part after alignment (m)
  ErrorStatistics ate_rotation_deg;  ///< APE rotation angle after alignment (degrees)
  /// RPE translation part (m); empty when the reference path is too short for two pairs'
  /// worth of delta (evo would refuse with "empty index list").
  std::optional<ErrorStatistics> rpe;
  std::optional<ErrorStatistics> rpe_rotation_deg;  ///< RPE rotation angle (degrees), with `rpe`
  double end_to_end_m = 0.0;           ///< ‖p_last - p_first‖ of the whole estimate
  double reference_end_to_end_m = 0.0; ///< the same for the whole reference
  TerminalDrift drift;                 ///< last matched pose, first poses aligned
  double drift_percent = 0.0;          ///< drift.translation_norm_m / path_length_m * 100 (NaN if 0 m)
  double path_length_m = 0.0;          ///< reference path over the matched poses
  double estimate_path_length_m = 0.0; ///< estimate path over the matched poses
};

/// The errors behind the statistics, pose by pose and pair by pair (fuse-eval --plot).
struct ErrorSeries {
  Trajectory reference;             ///< the matched reference poses
  Trajectory aligned;               ///< the matched estimate poses after the ATE alignment
  std::vector<double> distance_m;   ///< reference path travelled up to each matched pose
  std::vector<double> ape_m;        ///< APE translation part per matched pose
  std::vector<double> ape_deg;      ///< APE rotation angle per matched pose
  IdPairs rpe_pairs;                ///< RPE pairs (indices into the matched poses)
  std::vector<double> rpe_m;        ///< RPE translation part per pair
  std::vector<double> rpe_deg;      ///< RPE rotation angle per pair
};

/// Evaluates `estimate` against `reference` (the ground truth). Throws std::invalid_argument on a
/// bad config, non-finite poses or (timestamp association) timestamps that do not increase, and std::runtime_error when the trajectories cannot be evaluated (no matches,
/// fewer than kMinMatchedPoses matches, degenerate alignment).
/// With `series`, also fills the errors pose by pose.
EvaluationResult evaluate(const Trajectory& reference, const Trajectory& estimate,
                          const EvaluationConfig& config = {}, ErrorSeries* series = nullptr);

/// Fewest matched poses an evaluation accepts: Umeyama needs three non-collinear points.
inline constexpr std::size_t kMinMatchedPoses = 3;

/// The result as ordered (name, value) rows: ate_rmse_m, ..., matched_poses. Values that do
/// not exist (no RPE pairs, zero path) are NaN. Used for the text and JSON outputs.
std::vector<std::pair<std::string, double>> result_fields(const EvaluationResult& result);
/// "name: value" lines.
std::string format_text(const EvaluationResult& result);
/// One JSON object; NaN values are written as null.
std::string format_json(const EvaluationResult& result);

}  // namespace fuse::eval

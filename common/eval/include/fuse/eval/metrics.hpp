// Trajectory error metrics with evo's definitions (evo/core/metrics.py, filters.py):
// APE translation part, RPE translation part for a path delta in metres, and the terminal
// (end-of-run) drift of a closed or open run. All functions take associated trajectories:
// reference[i] and estimate[i] belong together.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "fuse/eval/trajectory.hpp"

namespace fuse::eval {

/// evo's statistics of an error array (PE.get_all_statistics): std is the population standard
/// deviation (numpy ddof = 0), median averages the two middle values of an even count.
struct ErrorStatistics {
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;
  double std = 0.0;
  double min = 0.0;
  double max = 0.0;
  double sse = 0.0;
  std::size_t count = 0;
};
/// Throws std::invalid_argument on an empty array.
ErrorStatistics compute_statistics(const std::vector<double>& errors);

/// APE translation part (evo metrics.APE, PoseRelation.translation_part): ‖p_est,i - p_ref,i‖.
std::vector<double> ape_translation_errors(const Trajectory& reference, const Trajectory& estimate);

/// APE rotation part in degrees (evo metrics.APE, PoseRelation.rotation_angle_deg): the angle of
/// R_ref,iᵀ R_est,i.
std::vector<double> ape_rotation_errors_deg(const Trajectory& reference, const Trajectory& estimate);

using IdPairs = std::vector<std::pair<std::size_t, std::size_t>>;
/// evo filters.filter_pairs_by_path, consecutive pairs: walking along the poses, the path is
/// accumulated and an index is kept (and the sum reset) each time the sum reaches delta_m;
/// consecutive kept indices form the pairs. (As in evo, index 0 itself is not kept.)
IdPairs pairs_by_path(const Trajectory& trajectory, double delta_m);

/// RPE translation part (evo metrics.RPE.rpe_base, TUM RGB-D notation):
/// E_ij = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j) with Q the reference, P the estimate; error ‖trans(E_ij)‖.
std::vector<double> rpe_translation_errors(const Trajectory& reference, const Trajectory& estimate,
                                           const IdPairs& pairs);

/// RPE rotation part in degrees (evo PoseRelation.rotation_angle_deg): the angle of E_ij above.
std::vector<double> rpe_rotation_errors_deg(const Trajectory& reference, const Trajectory& estimate,
                                            const IdPairs& pairs);

/// Σ‖p_{i+1} - p_i‖ (evo PosePath3D.path_length); 0 for fewer than two poses.
double path_length(const Trajectory& trajectory);

/// ‖p_last - p_first‖ of one trajectory: the loop-closure gap of a closed run.
double end_to_end_distance(const Trajectory& trajectory);

/// The error of the last pose after aligning the first poses: with A = T_ref,0 T_est,0⁻¹,
/// drift translation = p(A T_est,N) - p_ref,N in the reference frame, rotation error
/// R_err = R(A T_est,N) R_ref,N^T as ZYX Euler angles (yaw about z, pitch about y, roll about x).
struct TerminalDrift {
  Eigen::Vector3d translation_m = Eigen::Vector3d::Zero();
  double translation_norm_m = 0.0;
  double yaw_deg = 0.0;
  double pitch_deg = 0.0;
  double roll_deg = 0.0;
  double rotation_angle_deg = 0.0;  ///< angle of R_err (axis-angle)
};
/// Throws std::invalid_argument on empty or unequal trajectories.
TerminalDrift terminal_drift(const Trajectory& reference, const Trajectory& estimate);

}  // namespace fuse::eval

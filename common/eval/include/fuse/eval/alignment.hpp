// Umeyama least-squares alignment of two point sets (Umeyama, IEEE PAMI 1991), as evo's
// geometry.umeyama_alignment and PosePath3D.align.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>

#include "fuse/eval/trajectory.hpp"

namespace fuse::eval {

/// How the estimate is aligned to the reference before the absolute error (evo_ape flags).
enum class AlignmentMode {
  kNone,  ///< no alignment (evo_ape without -a)
  kSE3,   ///< rotation + translation (evo_ape -a)
  kSim3,  ///< rotation + translation + scale (evo_ape -a -s)
};
/// Parses "none" / "se3" / "sim3"; throws std::invalid_argument on anything else.
AlignmentMode parse_alignment_mode(const std::string& name);
std::string to_string(AlignmentMode mode);

/// A similarity transform y = scale * rotation * x + translation.
struct Similarity3 {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  double scale = 1.0;

  Eigen::Vector3d operator()(const Eigen::Vector3d& x) const { return scale * rotation * x + translation; }
};

/// Umeyama: the similarity minimising Σ‖y_i - (s R x_i + t)‖² (eqs. 34-43); with_scale = false
/// fixes s = 1 (SE(3)). x and y are 3xN with N >= 3. Throws std::invalid_argument on different
/// sizes, too few points or a degenerate configuration (covariance rank < 2, e.g. collinear).
Similarity3 umeyama_alignment(const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& y, bool with_scale);

/// Positions of a trajectory as a 3xN matrix.
Eigen::Matrix3Xd positions(const Trajectory& trajectory);

/// Applies T to every pose as evo does: p' = s R p + t, q' = R q (timestamps kept).
Trajectory transform(const Trajectory& trajectory, const Similarity3& T);

/// evo PosePath3D.align: the transform that aligns `estimate` onto `reference` (same length,
/// associated pose by pose); identity for AlignmentMode::kNone.
Similarity3 align(const Trajectory& reference, const Trajectory& estimate, AlignmentMode mode);

}  // namespace fuse::eval

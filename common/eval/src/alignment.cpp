// Umeyama alignment (Umeyama 1991, eqs. 34-43), following evo geometry.umeyama_alignment.
#include "fuse/eval/alignment.hpp"

#include <Eigen/SVD>
#include <limits>
#include <stdexcept>

namespace fuse::eval {

AlignmentMode parse_alignment_mode(const std::string& name) {
  if (name == "none") return AlignmentMode::kNone;
  if (name == "se3") return AlignmentMode::kSE3;
  if (name == "sim3") return AlignmentMode::kSim3;
  throw std::invalid_argument("unknown alignment '" + name + "' (expected none, se3 or sim3)");
}

std::string to_string(AlignmentMode mode) {
  switch (mode) {
    case AlignmentMode::kNone: return "none";
    case AlignmentMode::kSE3: return "se3";
    case AlignmentMode::kSim3: return "sim3";
  }
  return "unknown";
}

Similarity3 umeyama_alignment(const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& y, bool with_scale) {
  constexpr Eigen::Index kMinPoints = 3;
  if (x.cols() != y.cols()) throw std::invalid_argument("umeyama: point sets differ in size");
  if (x.cols() < kMinPoints) throw std::invalid_argument("umeyama: needs at least 3 points");
  const double n = static_cast<double>(x.cols());

  // Means (eqs. 34, 35), variance of x (eq. 36) and covariance Σ_xy (eq. 38).
  const Eigen::Vector3d mean_x = x.rowwise().mean();
  const Eigen::Vector3d mean_y = y.rowwise().mean();
  const Eigen::Matrix3Xd xc = x.colwise() - mean_x;
  const Eigen::Matrix3Xd yc = y.colwise() - mean_y;
  const double sigma_x = xc.squaredNorm() / n;
  const Eigen::Matrix3d cov_xy = yc * xc.transpose() / n;

  // SVD; rank(Σ_xy) >= 2 is needed for a unique rotation (text between eqs. 38 and 39).
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov_xy, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d d = svd.singularValues();
  const int rank = static_cast<int>((d.array() > std::numeric_limits<double>::epsilon()).count());
  if (rank < 2) throw std::invalid_argument("umeyama: degenerate point configuration (covariance rank < 2)");

  // S (eq. 43): flip the last axis when U V^T would be a reflection.
  Eigen::Vector3d s = Eigen::Vector3d::Ones();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) s.z() = -1.0;

  Similarity3 T;
  T.rotation = svd.matrixU() * s.asDiagonal() * svd.matrixV().transpose();  // eq. 40
  T.scale = with_scale ? d.dot(s) / sigma_x : 1.0;                          // eq. 42
  T.translation = mean_y - T.scale * T.rotation * mean_x;                   // eq. 41
  return T;
}

Eigen::Matrix3Xd positions(const Trajectory& trajectory) {
  Eigen::Matrix3Xd out(3, static_cast<Eigen::Index>(trajectory.size()));
  for (std::size_t i = 0; i < trajectory.size(); ++i) out.col(static_cast<Eigen::Index>(i)) = trajectory[i].p;
  return out;
}

Trajectory transform(const Trajectory& trajectory, const Similarity3& T) {
  const Eigen::Quaterniond rotation(T.rotation);
  Trajectory out = trajectory;
  for (StampedPose& pose : out) {
    pose.p = T(pose.p);
    pose.q = (rotation * pose.q).normalized();
  }
  return out;
}

Similarity3 align(const Trajectory& reference, const Trajectory& estimate, AlignmentMode mode) {
  if (mode == AlignmentMode::kNone) return {};
  return umeyama_alignment(positions(estimate), positions(reference), mode == AlignmentMode::kSim3);
}

}  // namespace fuse::eval

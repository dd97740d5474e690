// The smallest eigenpair of a symmetric positive semi-definite 3×3 matrix, and its other two
// eigenvalues, without trigonometry: the plane fit runs one per map query, and the closed-form
// solver (acos, cos, sin) was a sixth of the association's time.
#pragma once

#include <Eigen/Core>

namespace fuse {

struct SmallestEigen {
  Eigen::Vector3f vector = Eigen::Vector3f::UnitZ();  ///< unit eigenvector of values(0)
  Eigen::Vector3f values = Eigen::Vector3f::Zero();   ///< eigenvalues, ascending
};

/// For a scatter matrix C (symmetric, positive semi-definite). Newton's method on the
/// characteristic polynomial from 0 rises to the smallest root; its eigenvector is the largest
/// cross product of two rows of C − λ₀I. When λ₀ is not separated from λ₁ (points along a
/// line, or a blob), Newton converges slowly and the rows' span degenerates: those matrices go
/// to Eigen's iterative (QR) solver in double instead.
SmallestEigen smallest_eigen(const Eigen::Matrix3f& C);

}  // namespace fuse

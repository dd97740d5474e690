#include "fuse/association/smallest_eigen.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace fuse {

namespace {
/// Newton steps before a matrix goes to the iterative solver. A root well apart from the next
/// one takes 2–4 (quadratic convergence); a double root halves the error per step.
constexpr int kMaxNewtonSteps = 8;
/// Newton stops when a step is below this fraction of tr C.
constexpr double kStepTolerance = 1e-10;
/// The largest cross product of the rows of C − λ₀I is (λ₁λ₂)·v: below this fraction of (tr C)²
/// the rows span one direction only (λ₁ ≈ λ₀) and the normal is not theirs to give.
constexpr double kMinCrossRatio = 1e-8;

SmallestEigen iterative(const Eigen::Matrix3d& C) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C);
  return SmallestEigen{es.eigenvectors().col(0).cast<float>(), es.eigenvalues().cast<float>()};
}
}  // namespace

SmallestEigen smallest_eigen(const Eigen::Matrix3f& Cf) {
  const Eigen::Matrix3d C = Cf.cast<double>();
  // p(λ) = det(λI − C) = λ³ − c₂λ² + c₁λ − c₀: c₂ = tr C = Σλ, c₁ = Σ principal 2×2 minors
  // = λ₀λ₁ + λ₀λ₂ + λ₁λ₂, c₀ = det C = λ₀λ₁λ₂.
  const double c2 = C.trace();
  const double c1 = C(0, 0) * C(1, 1) - C(0, 1) * C(0, 1) + C(0, 0) * C(2, 2) - C(0, 2) * C(0, 2) + C(1, 1) * C(2, 2) -
                    C(1, 2) * C(1, 2);
  const double c0 = C.determinant();
  if (!(c2 > 0.0) || !std::isfinite(c0 + c1 + c2)) return iterative(C);
  // Left of λ₀ ≤ c₂/3, p < 0, p' > 0 and p'' = 6λ − 2c₂ < 0: each Newton step from λ ≤ λ₀ lands
  // at most on λ₀ (the tangent of a concave function lies above it), so from 0 the iterates rise
  // monotonically. det C ≤ 0 is a singular C (λ₀ = 0 up to rounding).
  double lambda = 0.0;
  if (c0 > 0.0) {
    bool converged = false;
    for (int i = 0; i < kMaxNewtonSteps && !converged; ++i) {
      const double p = ((lambda - c2) * lambda + c1) * lambda - c0;
      const double dp = (3.0 * lambda - 2.0 * c2) * lambda + c1;
      if (!(dp > 0.0)) return iterative(C);
      const double step = -p / dp;
      lambda += step;
      converged = step <= kStepTolerance * c2;
    }
    if (!converged) return iterative(C);
  }
  // (C − λ₀I)v = 0: v is orthogonal to every row, so parallel to the cross product of any two
  // independent rows. The largest of the three is the best conditioned.
  Eigen::Matrix3d M = C;
  M.diagonal().array() -= lambda;
  const Eigen::Vector3d r01 = M.row(0).cross(M.row(1));
  const Eigen::Vector3d r02 = M.row(0).cross(M.row(2));
  const Eigen::Vector3d r12 = M.row(1).cross(M.row(2));
  const double n01 = r01.squaredNorm();
  const double n02 = r02.squaredNorm();
  const double n12 = r12.squaredNorm();
  const double n_max = std::max({n01, n02, n12});
  if (!(n_max > kMinCrossRatio * kMinCrossRatio * c2 * c2 * c2 * c2)) return iterative(C);
  const Eigen::Vector3d& v = n01 == n_max ? r01 : n02 == n_max ? r02 : r12;
  // λ₁ + λ₂ = c₂ − λ₀ and λ₁λ₂ = c₁ − λ₀(λ₁ + λ₂); the smaller root as q/λ₂ avoids cancellation.
  const double s = c2 - lambda;
  const double q = std::max(c1 - lambda * s, 0.0);
  const double l2 = 0.5 * (s + std::sqrt(std::max(s * s - 4.0 * q, 0.0)));
  const double l1 = l2 > 0.0 ? q / l2 : 0.0;
  SmallestEigen out;
  out.vector = (v / std::sqrt(n_max)).cast<float>();
  out.values = Eigen::Vector3f(static_cast<float>(lambda), static_cast<float>(l1), static_cast<float>(l2));
  return out;
}

}  // namespace fuse

// SO(3) helpers on Eigen: exponential / logarithm maps and the right Jacobian.
// Convention: right perturbation, R = R̂ · Exp(δθ).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace fuse::so3 {

/// Skew-symmetric matrix [v]x such that [v]x w = v × w.
template <typename T>
inline Eigen::Matrix<T, 3, 3> hat(const Eigen::Matrix<T, 3, 1>& v) {
  Eigen::Matrix<T, 3, 3> m;
  m << T(0), -v.z(), v.y(), v.z(), T(0), -v.x(), -v.y(), v.x(), T(0);
  return m;
}

/// Exp: R^3 -> SO(3), Rodrigues' formula.
inline Eigen::Matrix3d Exp(const Eigen::Vector3d& w) {
  const double theta2 = w.squaredNorm();
  if (theta2 < 1e-16) return Eigen::Matrix3d::Identity() + hat(w);
  const double theta = std::sqrt(theta2);
  return Eigen::AngleAxisd(theta, w / theta).toRotationMatrix();
}

/// Log: SO(3) -> R^3 (rotation vector), robust near 0 and pi (via the quaternion).
inline Eigen::Vector3d Log(const Eigen::Matrix3d& R) {
  Eigen::Quaterniond q(R);
  if (q.w() < 0) q.coeffs() *= -1.0;
  const double sin_half = q.vec().norm();
  if (sin_half < 1e-12) return 2.0 * q.vec();
  const double theta = 2.0 * std::atan2(sin_half, q.w());
  return q.vec() * (theta / sin_half);
}

/// Right Jacobian J_r(w): Exp(w + δ) ≈ Exp(w) Exp(J_r(w) δ).
inline Eigen::Matrix3d RightJacobian(const Eigen::Vector3d& w) {
  const double theta2 = w.squaredNorm();
  const Eigen::Matrix3d W = hat(w);
  if (theta2 < 1e-10) return Eigen::Matrix3d::Identity() - 0.5 * W;
  const double theta = std::sqrt(theta2);
  return Eigen::Matrix3d::Identity() - (1.0 - std::cos(theta)) / theta2 * W +
         (theta - std::sin(theta)) / (theta2 * theta) * W * W;
}

/// Inverse of the right Jacobian.
inline Eigen::Matrix3d RightJacobianInverse(const Eigen::Vector3d& w) {
  const double theta2 = w.squaredNorm();
  const Eigen::Matrix3d W = hat(w);
  if (theta2 < 1e-10) return Eigen::Matrix3d::Identity() + 0.5 * W;
  const double theta = std::sqrt(theta2);
  return Eigen::Matrix3d::Identity() + 0.5 * W +
         (1.0 / theta2 - (1.0 + std::cos(theta)) / (2.0 * theta * std::sin(theta))) * W * W;
}

/// Re-orthonormalises a rotation matrix that accumulated round-off.
inline Eigen::Matrix3d Normalize(const Eigen::Matrix3d& R) {
  return Eigen::Quaterniond(R).normalized().toRotationMatrix();
}

}  // namespace fuse::so3

// SO(3) exponential / logarithm and the right Jacobian (fuse/core/so3.hpp).
#include "fuse/core/so3.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace {

using fuse::so3::Exp;
using fuse::so3::Log;
using fuse::so3::RightJacobian;
using fuse::so3::RightJacobianInverse;

constexpr double kPi = 3.14159265358979323846;
constexpr int kSamples = 200;

Eigen::Vector3d random_unit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
}

bool is_rotation(const Eigen::Matrix3d& R, double tol) {
  return (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < tol && std::abs(R.determinant() - 1.0) < tol;
}

// Log(Exp(w)) = w for |w| < π, over the whole range including the small-angle branch.
TEST(So3, ExpLogRoundTripOverAngles) {
  std::mt19937 rng(1);
  for (double angle : {0.0, 1e-12, 1e-9, 1e-6, 1e-3, 0.1, 1.0, 2.0, 3.0, kPi - 1e-3, kPi - 1e-6}) {
    for (int i = 0; i < kSamples / 10; ++i) {
      const Eigen::Vector3d w = angle * random_unit(rng);
      const Eigen::Matrix3d R = Exp(w);
      ASSERT_TRUE(is_rotation(R, 1e-12)) << "angle " << angle;
      const Eigen::Vector3d w2 = Log(R);
      EXPECT_LT((w2 - w).norm(), 1e-9) << "angle " << angle;
    }
  }
}

// Exp(Log(R)) = R for any rotation, including rotations by exactly π (Log is ambiguous in sign
// there, but both signs give the same rotation).
TEST(So3, LogExpRoundTripIncludingPi) {
  std::mt19937 rng(2);
  for (double angle : {kPi, kPi - 1e-9, 1e-14}) {
    for (int i = 0; i < kSamples / 10; ++i) {
      const Eigen::Matrix3d R = Eigen::AngleAxisd(angle, random_unit(rng)).toRotationMatrix();
      const Eigen::Vector3d w = Log(R);
      EXPECT_NEAR(w.norm(), angle, 1e-7);
      EXPECT_LT((Exp(w) - R).norm(), 1e-9) << "angle " << angle;
    }
  }
}

// Exp is the Rodrigues formula: Exp(θ a) rotates by θ about a (checked against AngleAxis, and on
// a vector: a point on the axis is fixed, a perpendicular one turns by θ).
TEST(So3, ExpMatchesRodrigues) {
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, 3).normalized();
  const double theta = 0.7;
  const Eigen::Matrix3d R = Exp(theta * axis);
  EXPECT_LT((R * axis - axis).norm(), 1e-14);
  const Eigen::Vector3d perp = axis.cross(Eigen::Vector3d::UnitX()).normalized();
  EXPECT_NEAR(std::acos((R * perp).dot(perp)), theta, 1e-12);
  EXPECT_LT(((R * perp).cross(perp) + std::sin(theta) * axis).norm(), 1e-12);  // right-handed turn
}

// J_r(w) against central differences: Exp(w + ε e_i) ≈ Exp(w) Exp(J_r(w) ε e_i), i.e.
// column i of J_r = Log(Exp(w)ᵀ Exp(w + ε e_i)) / ε.
TEST(So3, RightJacobianMatchesNumericDifferentiation) {
  constexpr double kEps = 1e-6;
  std::mt19937 rng(3);
  for (double angle : {0.0, 1e-6, 0.3, 1.5, 3.0}) {
    const Eigen::Vector3d w = angle * random_unit(rng);
    Eigen::Matrix3d J_num;
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d e = kEps * Eigen::Vector3d::Unit(i);
      const Eigen::Vector3d plus = Log(Exp(w).transpose() * Exp(w + e));
      const Eigen::Vector3d minus = Log(Exp(w).transpose() * Exp(w - e));
      J_num.col(i) = (plus - minus) / (2.0 * kEps);
    }
    EXPECT_LT((RightJacobian(w) - J_num).norm(), 1e-7) << "angle " << angle;
    EXPECT_LT((RightJacobianInverse(w) * RightJacobian(w) - Eigen::Matrix3d::Identity()).norm(), 1e-9)
        << "angle " << angle;
  }
}

}  // namespace

// Point-to-plane Jacobian (point_to_plane_model.hpp) against numeric differentiation of the
// residual r = nᵀ(R_WI (R_IL p_L + p_IL) + p_WI) + d with boxplus perturbations, every column, and
// the time offset's column from the motion at the scan end.
#include "fuse/estimation/point_to_plane_model.hpp"

#include <gtest/gtest.h>

#include "test_helpers.hpp"

namespace fuse {
namespace {

constexpr double kEps = 1e-6;
constexpr double kTol = 1e-7;

Constraint random_constraint(std::mt19937& rng) {
  Constraint c;
  c.point = test::random_vector(rng, 10.0).cast<float>();
  c.normal = test::random_vector(rng, 1.0).normalized().cast<float>();
  c.d = static_cast<float>(test::random_vector(rng, 5.0).x());
  return c;
}

TEST(PointToPlane, JacobianMatchesNumericDifferentiation) {
  std::mt19937 rng(40);
  for (int trial = 0; trial < 100; ++trial) {
    const NavState x = test::random_state(rng);
    const Constraint c = random_constraint(rng);
    const Eigen::Matrix<double, 1, kObsDim> H = point_to_plane_jacobian(x, c);
    for (int i = 0; i < kObsDim; ++i) {
      const StateVector e = kEps * StateVector::Unit(i);
      const double numeric =
          (point_to_plane_residual(x.boxplus(e), c) - point_to_plane_residual(x.boxplus(-e), c)) / (2 * kEps);
      EXPECT_NEAR(H(i), numeric, kTol * (1.0 + std::abs(numeric))) << "column " << i << " trial " << trial;
    }
  }
}

TEST(PointToPlane, ResidualIsSignedDistance) {
  NavState x;
  x.p = Eigen::Vector3d(1, 0, 0);
  x.p_IL = Eigen::Vector3d(0, 0, 0.5);
  Constraint c;
  c.point = Eigen::Vector3f(0, 0, 1);
  c.normal = Eigen::Vector3f(0, 0, 1);
  c.d = -1.0f;  // plane z = 1
  EXPECT_NEAR(point_to_plane_residual(x, c), 0.5, 1e-12);  // point at z = 1.5
}

}  // namespace
}  // namespace fuse

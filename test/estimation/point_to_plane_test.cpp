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

// The time offset's column: a scan placed with offset t_d⁰ is seen at moved_along(x, ω, t_d − t_d⁰);
// the normal equations' t_d row and column (add_time_offset_column) equal Σ w h hᵀ and Σ w h r with
// h the numeric derivative of each residual by t_d, alongside the pose columns.
TEST(PointToPlane, TimeOffsetColumnMatchesNumericDifferentiation) {
  std::mt19937 rng(41);
  for (int trial = 0; trial < 20; ++trial) {
    NavState x = test::random_state(rng);
    const double td0 = x.td;
    const Eigen::Vector3d omega = test::random_vector(rng, 1.0);
    LinearSystem sys;
    Eigen::Matrix<double, kObsDim, kObsDim> L = Eigen::Matrix<double, kObsDim, kObsDim>::Zero();
    Eigen::Matrix<double, kObsDim, 1> g = Eigen::Matrix<double, kObsDim, 1>::Zero();
    for (int j = 0; j < 30; ++j) {
      const Constraint c = random_constraint(rng);
      const double w = 1.0 + j % 3;
      Eigen::Matrix<double, 1, kObsDim> H = point_to_plane_jacobian(x, c);
      const double r = point_to_plane_residual(x, c);
      sys.information.noalias() += w * H.transpose() * H;
      sys.gradient.noalias() += w * r * H.transpose();
      NavState plus = x, minus = x;
      plus.td += kEps;
      minus.td -= kEps;
      H(Idx::kTimeOffset) = (point_to_plane_residual(moved_along(plus, omega, plus.td - td0), c) -
                             point_to_plane_residual(moved_along(minus, omega, minus.td - td0), c)) /
                            (2 * kEps);
      L.noalias() += w * H.transpose() * H;
      g.noalias() += w * r * H.transpose();
    }
    add_time_offset_column(sys, x.v, omega);
    EXPECT_LT((sys.information - L).cwiseAbs().maxCoeff(), 1e-5 * (1.0 + L.cwiseAbs().maxCoeff())) << trial;
    EXPECT_LT((sys.gradient - g).cwiseAbs().maxCoeff(), 1e-5 * (1.0 + g.cwiseAbs().maxCoeff())) << trial;
  }
}

// The residual is the signed distance of the transformed point to the plane.
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

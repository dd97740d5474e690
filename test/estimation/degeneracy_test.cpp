// Degeneracy-aware attenuation (degeneracy.hpp) on synthetic information matrices built from
// point-to-plane Jacobians: Λ = Σ HᵀH, g = Σ Hᵀr over [δp, δθ] (rotation scaled by ℓ).
#include "fuse/estimation/degeneracy.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include "fuse/estimation/point_to_plane_model.hpp"

namespace fuse {
namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;

struct Plane {
  Eigen::Vector3d normal;
  std::vector<Eigen::Vector3d> points;
};

/// Adds the rows of point-to-plane constraints at the identity state (w = 1, residual r = 0.01·i
/// so that the gradient is non-zero) and sets ℓ to the RMS lever arm, as PointToPlaneModel does.
LinearSystem system_of(const std::vector<Plane>& planes) {
  LinearSystem sys;
  const NavState x;
  double lever2 = 0.0;
  for (const Plane& plane : planes) {
    for (const Eigen::Vector3d& p : plane.points) {
      Constraint c;
      c.point = p.cast<float>();
      c.normal = plane.normal.cast<float>();
      const Eigen::Matrix<double, 1, kObsDim> H = point_to_plane_jacobian(x, c);
      const double r = 0.01 * static_cast<double>(sys.count % 7) - 0.03;
      sys.information += H.transpose() * H;
      sys.gradient += r * H.transpose();
      sys.cost += r * r;
      lever2 += p.squaredNorm();
      ++sys.count;
    }
  }
  sys.characteristic_length = std::sqrt(lever2 / static_cast<double>(sys.count));
  return sys;
}

/// A corridor along x: walls y = ±1.5 (normals ±y), floor and ceiling z = ±1.2 (normals ±z), points
/// on a symmetric grid in x ∈ [−4, 4]; optionally a few points on the end wall x = 5 (normal +x) at
/// symmetric (y, z) so that x stays an exact eigen-direction.
std::vector<Plane> corridor(int end_wall_points) {
  std::vector<Plane> planes;
  for (double s : {-1.0, 1.0}) {
    Plane wall{Eigen::Vector3d(0, s, 0), {}}, floor{Eigen::Vector3d(0, 0, s), {}};
    for (double x = -4.0; x <= 4.0 + 1e-9; x += 0.5) {
      for (double u = -1.0; u <= 1.0 + 1e-9; u += 0.5) {
        wall.points.emplace_back(x, 1.5 * s, 1.2 * u);
        floor.points.emplace_back(x, 1.5 * u, 1.2 * s);
      }
    }
    planes.push_back(wall);
    planes.push_back(floor);
  }
  Plane end{Eigen::Vector3d(1, 0, 0), {}};
  const double offsets[][2] = {{0.5, 0.5}, {-0.5, -0.5}, {0.5, -0.5}, {-0.5, 0.5}};
  for (int i = 0; i < end_wall_points; ++i) end.points.emplace_back(5.0, offsets[i % 4][0], offsets[i % 4][1]);
  if (end_wall_points > 0) planes.push_back(end);
  return planes;
}

/// A room: every wall, floor and ceiling observed.
std::vector<Plane> room() {
  std::vector<Plane> planes = corridor(0);
  for (double s : {-1.0, 1.0}) {
    Plane wall{Eigen::Vector3d(s, 0, 0), {}};
    for (double y = -1.5; y <= 1.5 + 1e-9; y += 0.5) {
      for (double z = -1.2; z <= 1.2 + 1e-9; z += 0.4) wall.points.emplace_back(4.0 * s, y, z);
    }
    planes.push_back(wall);
  }
  return planes;
}

/// γ = smoothstep((λ/λ_max − ρ_lo)/(ρ_hi − ρ_lo)) of the along-corridor direction, computed here
/// from Λ_xx (x is an exact eigen-direction of the symmetric corridor) and λ_max of S⁻¹ΛS⁻¹.
double expected_gamma_x(const LinearSystem& sys, const DegeneracyConfig& cfg) {
  Eigen::Matrix<double, 6, 1> s_inv;
  const double l = sys.characteristic_length;
  s_inv << 1, 1, 1, 1 / l, 1 / l, 1 / l;
  const Mat6 info_n = s_inv.asDiagonal() * sys.information.topLeftCorner<6, 6>() * s_inv.asDiagonal();
  const double lambda_max = Eigen::SelfAdjointEigenSolver<Mat6>(info_n).eigenvalues().maxCoeff();
  const double a = std::clamp((sys.information(0, 0) / lambda_max - cfg.ratio_low) / (cfg.ratio_high - cfg.ratio_low), 0.0, 1.0);
  return a * a * (3 - 2 * a);
}

TEST(Degeneracy, CorridorWithoutAxialNormalsHasZeroGammaAlongIt) {
  LinearSystem sys = system_of(corridor(0));
  ASSERT_EQ(sys.information(0, 0), 0.0);
  const DegeneracyReport rep = attenuate_degenerate_directions(sys, DegeneracyConfig{});
  EXPECT_EQ(rep.gamma(0), 0.0);
  for (int i = 1; i < 6; ++i) EXPECT_EQ(rep.gamma(i), 1.0) << "eigen-direction " << i;
  EXPECT_EQ(rep.min_gamma, 0.0);
  EXPECT_NEAR(rep.min_eigenvalue_translation, 0.0, 1e-9);
  EXPECT_GT(rep.min_eigenvalue_rotation, 1.0);
}

// A few weak x normals: 0 < γ_x < 1; the information and gradient are scaled by γ along x only.
TEST(Degeneracy, WeakAxialNormalsAttenuateOnlyThatDirection) {
  const LinearSystem before = system_of(corridor(2));
  LinearSystem sys = before;
  const DegeneracyConfig cfg;
  const DegeneracyReport rep = attenuate_degenerate_directions(sys, cfg);
  const double gamma_x = expected_gamma_x(before, cfg);
  ASSERT_GT(gamma_x, 0.05);
  ASSERT_LT(gamma_x, 0.95);
  EXPECT_NEAR(rep.gamma(0), gamma_x, 1e-9);
  for (int i = 1; i < 6; ++i) EXPECT_EQ(rep.gamma(i), 1.0) << "eigen-direction " << i;

  // Pose block: Λ'_pp = Λ_pp − (1 − γ)·λ_x e_x e_xᵀ; the pose-extrinsic cross terms and the gradient
  // go through the projector M = I − (1 − γ) e_x e_xᵀ: row 0 (and column 0) scaled by γ.
  ObsMatrix expected_info = before.information;
  expected_info.row(0) *= gamma_x;
  expected_info.col(0).tail<kObsDim - 1>() *= gamma_x;
  ASSERT_GT(before.information.row(0).tail<kObsDim - 6>().norm(), 0.0);  // the cross terms are exercised
  ObsVector expected_grad = before.gradient;
  expected_grad(0) *= gamma_x;
  EXPECT_LT((sys.information - expected_info).cwiseAbs().maxCoeff(), 1e-9 * before.information.norm())
      << "attenuated:\n" << sys.information << "\nbefore:\n" << before.information;
  EXPECT_LT((sys.gradient - expected_grad).cwiseAbs().maxCoeff(), 1e-9 * before.gradient.norm());
  EXPECT_LT(sys.information(0, 0), before.information(0, 0));
}

TEST(Degeneracy, WellConditionedSystemIsUnchanged) {
  const LinearSystem before = system_of(room());
  LinearSystem sys = before;
  const DegeneracyReport rep = attenuate_degenerate_directions(sys, DegeneracyConfig{});
  EXPECT_EQ(rep.min_gamma, 1.0);
  EXPECT_EQ(sys.information, before.information);
  EXPECT_EQ(sys.gradient, before.gradient);
}

// The ablation switch: nothing changes, but the analysis is still reported.
TEST(Degeneracy, DisabledReportsButDoesNotChange) {
  const LinearSystem before = system_of(corridor(2));
  LinearSystem sys = before;
  DegeneracyConfig cfg;
  cfg.enabled = false;
  const DegeneracyReport rep = attenuate_degenerate_directions(sys, cfg);
  EXPECT_EQ(sys.information, before.information);
  EXPECT_EQ(sys.gradient, before.gradient);
  EXPECT_NEAR(rep.gamma(0), expected_gamma_x(before, cfg), 1e-9);
  EXPECT_LT(rep.min_gamma, 1.0);
  EXPECT_GT(rep.eigenvalues(5), 0.0);
}

}  // namespace
}  // namespace fuse

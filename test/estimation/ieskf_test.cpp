// IESKF update (ieskf.hpp) on a synthetic plane map with exact correspondences: the update
// recovers the true pose from an offset prior; the posterior covariance shrinks along observed
// directions and equals the prior along unobserved ones.
#include "fuse/estimation/ieskf.hpp"

#include <gtest/gtest.h>

#include "fuse/estimation/point_to_plane_model.hpp"
#include "test_helpers.hpp"

namespace fuse {
namespace {

constexpr double kPointSigma = 0.02;  // m

/// A measurement model over fixed correspondences (no association): r_j and H_j of each constraint.
class FixedPlanesModel final : public MeasurementModel {
 public:
  explicit FixedPlanesModel(std::vector<Constraint> constraints) : constraints_(std::move(constraints)) {}
  bool linearize(const NavState& x, int, LinearSystem& out) override {
    out = LinearSystem{};
    const double w = 1.0 / (kPointSigma * kPointSigma);
    double lever2 = 0.0;
    for (const Constraint& c : constraints_) {
      const Eigen::Matrix<double, 1, kObsDim> H = point_to_plane_jacobian(x, c);
      const double r = point_to_plane_residual(x, c);
      out.information += w * H.transpose() * H;
      out.gradient += w * r * H.transpose();
      out.cost += w * r * r;
      lever2 += (x.R_IL * c.point.cast<double>() + x.p_IL).squaredNorm();
    }
    out.count = constraints_.size();
    out.characteristic_length = std::sqrt(lever2 / static_cast<double>(out.count));
    return out.count > 0;
  }

 private:
  std::vector<Constraint> constraints_;
};

struct WorldPlane {
  Eigen::Vector3d n;
  double d;  // nᵀx + d = 0
};

/// Points sampled on each plane near the sensor, expressed in the LiDAR frame of the true state.
std::vector<Constraint> observe(const std::vector<WorldPlane>& planes, const NavState& truth, std::mt19937& rng) {
  constexpr int kPerPlane = 60;
  const Eigen::Isometry3d T_LW = (truth.T_WI() * truth.T_IL()).inverse();
  std::vector<Constraint> out;
  for (const WorldPlane& pl : planes) {
    for (int i = 0; i < kPerPlane; ++i) {
      Eigen::Vector3d p = truth.p + test::random_vector(rng, 4.0);
      p -= (pl.n.dot(p) + pl.d) * pl.n;  // project onto the plane
      Constraint c;
      c.point = (T_LW * p).cast<float>();
      c.normal = pl.n.cast<float>();
      c.d = static_cast<float>(pl.d);
      out.push_back(c);
    }
  }
  return out;
}

NavState true_state() {
  NavState x;
  x.p = Eigen::Vector3d(1.0, -2.0, 0.5);
  x.R = so3::Exp(Eigen::Vector3d(0.05, -0.1, 0.8));
  x.R_IL = so3::Exp(Eigen::Vector3d(0.0, 0.0, 0.1));
  x.p_IL = Eigen::Vector3d(0.05, 0.0, 0.1);
  x.v = Eigen::Vector3d(0.5, 0.2, 0.0);
  return x;
}

/// Prior covariance: pose, velocity and biases estimated; extrinsic and gravity fixed (zero).
StateCovariance prior_covariance() {
  StateCovariance P = StateCovariance::Zero();
  P.block<3, 3>(Idx::kPos, Idx::kPos) = 0.2 * 0.2 * Eigen::Matrix3d::Identity();
  P.block<3, 3>(Idx::kRot, Idx::kRot) = 0.05 * 0.05 * Eigen::Matrix3d::Identity();
  P.block<3, 3>(Idx::kVel, Idx::kVel) = 0.1 * 0.1 * Eigen::Matrix3d::Identity();
  P.block<3, 3>(Idx::kBg, Idx::kBg) = 1e-3 * 1e-3 * Eigen::Matrix3d::Identity();
  P.block<3, 3>(Idx::kBa, Idx::kBa) = 0.05 * 0.05 * Eigen::Matrix3d::Identity();
  return P;
}

UpdateConfig tight_update() {
  UpdateConfig cfg;
  cfg.max_iterations = 10;
  cfg.convergence_translation = 1e-7;
  cfg.convergence_rotation = 1e-8;
  return cfg;
}

NavState offset_prior(const NavState& truth) {
  StateVector offset = StateVector::Zero();
  offset.segment<3>(Idx::kPos) = Eigen::Vector3d(0.15, -0.1, 0.08);
  offset.segment<3>(Idx::kRot) = Eigen::Vector3d(0.02, -0.015, 0.03);
  return truth.boxplus(offset);
}

// Several planes with varied normals observe the full pose: the update lands on the truth (the
// prior's pull is ~ P_post·P⁻¹·offset, of order 1e-6 here) and the pose covariance shrinks.
TEST(Ieskf, RecoversTruePoseFromOffsetPrior) {
  std::mt19937 rng(50);
  const NavState truth = true_state();
  const std::vector<WorldPlane> planes{{Eigen::Vector3d(0, 0, 1), 1.0},
                                       {Eigen::Vector3d(1, 0, 0), -6.0},
                                       {Eigen::Vector3d(0, 1, 0), 5.0},
                                       {Eigen::Vector3d(1, 1, 1).normalized(), -4.0},
                                       {Eigen::Vector3d(-1, 0.5, 0.2).normalized(), -5.0}};
  FixedPlanesModel model(observe(planes, truth, rng));
  NavState x = offset_prior(truth);
  StateCovariance P = prior_covariance();
  const StateCovariance P_prior = P;
  IeskfBackend backend(tight_update());
  const UpdateResult res = backend.update(x, P, model);
  ASSERT_TRUE(res.updated);
  EXPECT_TRUE(res.converged);
  EXPECT_GT(res.cost_before, 1e3 * res.cost_after + 1.0);
  EXPECT_LT((x.p - truth.p).norm(), 1e-4);
  EXPECT_LT(test::rotation_error(x.R, truth.R), 1e-4);
  EXPECT_EQ(res.degeneracy.min_gamma, 1.0);
  for (int i = 0; i < 6; ++i) EXPECT_LT(P(i, i), 0.1 * P_prior(i, i)) << "pose dimension " << i;
  // Fixed dimensions (zero prior variance) stay fixed.
  EXPECT_EQ(x.p_IL, truth.p_IL);
  EXPECT_EQ(x.g, truth.g);
  EXPECT_TRUE((P.block<3, 3>(Idx::kExtPos, Idx::kExtPos).isZero(0.0)));
}

// Only z-normal planes (floor and a raised platform): z, roll and pitch are observed; x, y and yaw
// are not, so their posterior variance equals the prior (the prior is uncorrelated here).
TEST(Ieskf, UnobservedDirectionsKeepPriorCovariance) {
  std::mt19937 rng(51);
  const NavState truth = true_state();
  const std::vector<WorldPlane> planes{{Eigen::Vector3d(0, 0, 1), 1.0}, {Eigen::Vector3d(0, 0, 1), -2.0}};
  FixedPlanesModel model(observe(planes, truth, rng));
  NavState x = offset_prior(truth);
  StateCovariance P = prior_covariance();
  const StateCovariance P_prior = P;
  IeskfBackend backend(tight_update());
  ASSERT_TRUE(backend.update(x, P, model).updated);

  // Observed: z (world, = δp_z since δp is in the world frame) and the tilt.
  EXPECT_NEAR(x.p.z(), truth.p.z(), 1e-4);
  EXPECT_LT(P(Idx::kPos + 2, Idx::kPos + 2), 0.01 * P_prior(Idx::kPos + 2, Idx::kPos + 2));
  const Eigen::Vector3d up_true = truth.R.transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_est = x.R.transpose() * Eigen::Vector3d::UnitZ();
  EXPECT_LT((up_true - up_est).norm(), 1e-4);
  // Unobserved: world x, y and the rotation about world z (δθ is in the body frame: the body
  // direction of world z is Rᵀẑ, so its variance is (Rᵀẑ)ᵀ P_θθ (Rᵀẑ)).
  for (int i : {Idx::kPos, Idx::kPos + 1}) EXPECT_NEAR(P(i, i), P_prior(i, i), 1e-9 * P_prior(i, i));
  EXPECT_NEAR(x.p.x(), offset_prior(truth).p.x(), 1e-9);
  const Eigen::Matrix3d P_rot = P.block<3, 3>(Idx::kRot, Idx::kRot);
  const Eigen::Matrix3d P_rot_prior = P_prior.block<3, 3>(Idx::kRot, Idx::kRot);
  EXPECT_NEAR(up_true.dot(P_rot * up_true), up_true.dot(P_rot_prior * up_true), 1e-6 * P_rot_prior(0, 0));
  // Velocity and biases are not touched by a pose-only measurement with an uncorrelated prior.
  EXPECT_LT((P.block<9, 9>(Idx::kVel, Idx::kVel) - P_prior.block<9, 9>(Idx::kVel, Idx::kVel)).norm(), 1e-12);
}

TEST(Ieskf, NoConstraintsNoUpdate) {
  FixedPlanesModel model({});
  NavState x = true_state();
  StateCovariance P = prior_covariance();
  const StateCovariance P_prior = P;
  IeskfBackend backend(UpdateConfig{});
  EXPECT_FALSE(backend.update(x, P, model).updated);
  EXPECT_EQ(P, P_prior);
  EXPECT_EQ(x.p, true_state().p);
}

}  // namespace
}  // namespace fuse

// The update backends behind make_update_backend (ekf, eskf, ieskf, nano): config and factory,
// the ESKF reset Jacobian against finite differences, agreement with the Kalman posterior on a
// linear-Gaussian problem, and the degeneracy-aware attenuation kept by every backend.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>

#include "backend_test_models.hpp"
#include "fuse/estimation/eskf.hpp"
#include "fuse/estimation/estimator_config.hpp"
#include "fuse/estimation/update_backend.hpp"

namespace fuse {
namespace {

UpdateConfig load_update(const std::string& yaml) {
  ConfigNode node = ConfigNode::from_string(yaml);
  UpdateConfig c;
  c.load(node);
  return c;
}

TEST(UpdateBackends, FactoryNamesEveryBackend) {
  for (const std::string& name : update_backend_names()) {
    UpdateConfig c;
    c.backend = name;
    EXPECT_EQ(make_update_backend(c)->name(), name);
  }
}

TEST(UpdateBackends, ConfigSectionsAndValidation) {
  const UpdateConfig c = load_update(
      "backend: nano\nmax_iterations: 4\nieskf: {max_iterations: 7}\n"
      "nano: {step: 0.5, max_iterations: 9, kl_tolerance: 1.0e-3, cubature: false, adaptive_cubature: false}\n");
  EXPECT_EQ(c.backend, "nano");
  EXPECT_EQ(c.max_iterations, 7);  // the ieskf section wins over the flat key
  EXPECT_DOUBLE_EQ(c.nano.step, 0.5);
  EXPECT_EQ(c.nano.max_iterations, 9);
  EXPECT_DOUBLE_EQ(c.nano.kl_tolerance, 1e-3);
  EXPECT_FALSE(c.nano.cubature);
  EXPECT_FALSE(c.nano.adaptive_cubature);
  EXPECT_EQ(load_update("backend: eskf\neskf: {}\n").backend, "eskf");
  EXPECT_THROW(load_update("backend: ukf\n"), ConfigError);
  EXPECT_THROW(load_update("nano: {step: 1.5}\n"), ConfigError);
  EXPECT_THROW(load_update("nano: {beta: 0.5}\n"), ConfigError);
  EXPECT_THROW(load_update("ekf: {max_iterations: 2}\n"), ConfigError);
}

// The shipped configuration files load unchanged, with every backend selectable.
TEST(UpdateBackends, ShippedConfigsLoad) {
  for (const char* file : {"mid360.yaml", "spinning.yaml"}) {
    for (const std::string& name : update_backend_names()) {
      const YAML::Node root = load_yaml_file(std::string(FUSE_CONFIG_DIR) + "/" + file, {"estimator.update.backend=" + name});
      ConfigNode node(root["estimator"], "estimator");
      EstimatorConfig config;
      ASSERT_NO_THROW(config.load(node)) << file;
      EXPECT_EQ(config.update.backend, name);
    }
  }
}

// G = ∂((x̂ ⊞ (δ + ε)) ⊟ (x̂ ⊞ δ))/∂ε at ε = 0 by central differences; the first-order G agrees to O(|δ|²).
TEST(UpdateBackends, EskfResetJacobianMatchesFiniteDifferences) {
  std::mt19937 rng(7);
  const NavState prior = test::random_state(rng);
  const StateVector delta = test::random_tangent(rng, 0.03);
  const NavState post = prior.boxplus(delta);
  StateCovariance G_num;
  constexpr double h = 1e-6;
  for (int i = 0; i < kStateDim; ++i) {
    StateVector e = StateVector::Zero();
    e(i) = h;
    G_num.col(i) = (prior.boxplus(delta + e).boxminus(post) - prior.boxplus(delta - e).boxminus(post)) / (2 * h);
  }
  const StateCovariance G = eskf_reset_jacobian(prior, delta);
  EXPECT_LT((G - G_num).cwiseAbs().maxCoeff(), 2e-3);
  // ... and it is a better model of the reset than no reset at all.
  EXPECT_LT((G - G_num).norm(), 0.1 * (StateCovariance::Identity() - G_num).norm());
}

struct LinearProblem {
  NavState prior;
  StateCovariance P;
  test::LinearObservation model;
  NavState posterior;      ///< Kalman
  StateCovariance P_post;  ///< Kalman
};

/// z = A [p; p_IL] + v with a prior correlating the additive blocks (p, p_IL, v, b_g, b_a); the
/// rotations have an uncorrelated prior (unobserved, so they do not move) and gravity is fixed.
LinearProblem linear_problem(std::mt19937& rng) {
  NavState prior = test::random_state(rng);
  const std::vector<int> additive{0, 1, 2, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20};
  const int m = static_cast<int>(additive.size());
  std::normal_distribution<double> N(0.0, 1.0);
  Eigen::MatrixXd B(m, m);
  for (int r = 0; r < m; ++r) {
    for (int c = 0; c < m; ++c) B(r, c) = N(rng);
  }
  const Eigen::MatrixXd Pa = 0.04 * (B * B.transpose() / m + 0.2 * Eigen::MatrixXd::Identity(m, m));
  StateCovariance P = StateCovariance::Zero();
  for (int r = 0; r < m; ++r) {
    for (int c = 0; c < m; ++c) P(additive[r], additive[c]) = Pa(r, c);
  }
  for (int i = Idx::kRot; i < Idx::kRot + 6; ++i) P(i, i) = 1e-3;
  const int k = 8;
  Eigen::MatrixXd A(k, 6);
  for (int r = 0; r < k; ++r) {
    for (int c = 0; c < 6; ++c) A(r, c) = N(rng);
  }
  Eigen::VectorXd sig(k);
  for (int r = 0; r < k; ++r) sig(r) = 0.02 + 0.05 * std::abs(N(rng));
  const Eigen::MatrixXd W = sig.cwiseInverse().cwiseAbs2().asDiagonal();
  Eigen::VectorXd z(k);
  for (int r = 0; r < k; ++r) z(r) = N(rng);
  test::LinearObservation model(A, z, W);
  // Kalman (covariance form): K = P Hᵀ (H P Hᵀ + W⁻¹)⁻¹, δ = −K r(x̂), P⁺ = (I − K H) P.
  const Eigen::MatrixXd H = model.H();
  const Eigen::MatrixXd S = H * P * H.transpose() + Eigen::MatrixXd(W.inverse());
  const Eigen::MatrixXd K = P * H.transpose() * S.inverse();
  const StateVector delta = -K * model.residual(prior);
  const StateCovariance P_post = (StateCovariance::Identity() - K * H) * P;
  return {prior, P, model, prior.boxplus(delta), P_post};
}

UpdateConfig linear_config(const std::string& backend) {
  UpdateConfig c;
  c.backend = backend;
  c.degeneracy.enabled = false;
  c.max_iterations = 10;
  c.convergence_translation = 1e-9;
  c.convergence_rotation = 1e-9;
  c.nano.max_iterations = 10;
  c.nano.kl_tolerance = 1e-12;
  return c;
}

TEST(UpdateBackends, LinearGaussianAllEqualTheKalmanPosterior) {
  for (int seed = 0; seed < 3; ++seed) {
    for (const std::string& name : update_backend_names()) {
      std::mt19937 rng(100 + seed);
      LinearProblem lp = linear_problem(rng);
      NavState x = lp.prior;
      StateCovariance P = lp.P;
      const UpdateResult res = make_update_backend(linear_config(name))->update(x, P, lp.model);
      ASSERT_TRUE(res.updated) << name;
      const StateVector err = x.boxminus(lp.posterior);
      EXPECT_LT(err.norm(), 1e-9) << name << " seed " << seed << " state error " << err.transpose();
      EXPECT_LT((P - lp.P_post).norm(), 1e-9 * lp.P.norm()) << name << " seed " << seed;
    }
  }
}

// Only z-normal planes: x, y and yaw are unobserved. With the degeneracy-aware attenuation every
// backend leaves their (uncorrelated) prior variance and position untouched.
TEST(UpdateBackends, AllKeepPriorAlongUnobservedDirections) {
  NavState truth;
  truth.p = Eigen::Vector3d(1.0, -2.0, 0.5);
  truth.R = so3::Exp(Eigen::Vector3d(0.05, -0.1, 0.8));
  std::mt19937 rng(9);
  const auto constraints = test::FixedPlanes::observe({Eigen::Vector4d(0, 0, 1, 1.0), Eigen::Vector4d(0, 0, 1, -2.0)}, truth, rng);
  StateVector offset = StateVector::Zero();
  offset.head<6>() << 0.15, -0.1, 0.08, 0.02, -0.015, 0.03;
  StateCovariance P0 = StateCovariance::Zero();
  P0.block<3, 3>(Idx::kPos, Idx::kPos) = 0.04 * Eigen::Matrix3d::Identity();
  P0.block<3, 3>(Idx::kRot, Idx::kRot) = 0.0025 * Eigen::Matrix3d::Identity();
  P0.block<3, 3>(Idx::kVel, Idx::kVel) = 0.01 * Eigen::Matrix3d::Identity();
  for (const std::string& name : update_backend_names()) {
    test::FixedPlanes model(constraints, 0.02);
    NavState x = truth.boxplus(offset);
    StateCovariance P = P0;
    UpdateConfig c;
    c.backend = name;
    ASSERT_TRUE(make_update_backend(c)->update(x, P, model).updated) << name;
    EXPECT_NEAR(x.p.z(), truth.p.z(), name == "ekf" || name == "eskf" ? 5e-3 : 1e-4) << name;
    EXPECT_NEAR(x.p.x(), truth.boxplus(offset).p.x(), 1e-9) << name;
    for (int i : {Idx::kPos, Idx::kPos + 1}) EXPECT_NEAR(P(i, i), P0(i, i), 1e-9 * P0(i, i)) << name;
    EXPECT_LT(P(Idx::kPos + 2, Idx::kPos + 2), 0.01 * P0(Idx::kPos + 2, Idx::kPos + 2)) << name;
  }
}

TEST(UpdateBackends, NoConstraintsNoUpdate) {
  for (const std::string& name : update_backend_names()) {
    test::FixedPlanes model({}, 0.02);
    NavState x;
    StateCovariance P = 0.01 * StateCovariance::Identity();
    const StateCovariance P0 = P;
    UpdateConfig c;
    c.backend = name;
    EXPECT_FALSE(make_update_backend(c)->update(x, P, model).updated) << name;
    EXPECT_EQ(P, P0) << name;
    EXPECT_EQ(x.p, NavState().p) << name;
  }
}

}  // namespace
}  // namespace fuse

// Manifold operations of NavState (state.hpp): x ⊞ (y ⊟ x) = y and (x ⊞ δ) ⊟ x = δ for every
// block, gravity on the sphere S² included.
#include "fuse/estimation/state.hpp"

#include <gtest/gtest.h>

#include "test_helpers.hpp"

namespace fuse {
namespace {

constexpr int kTrials = 200;

void expect_states_equal(const NavState& a, const NavState& b, double tol) {
  EXPECT_LT((a.p - b.p).norm(), tol);
  EXPECT_LT((a.R - b.R).norm(), tol);
  EXPECT_LT((a.R_IL - b.R_IL).norm(), tol);
  EXPECT_LT((a.p_IL - b.p_IL).norm(), tol);
  EXPECT_LT(std::abs(a.td - b.td), tol);
  EXPECT_LT((a.v - b.v).norm(), tol);
  EXPECT_LT((a.bg - b.bg).norm(), tol);
  EXPECT_LT((a.ba - b.ba).norm(), tol);
  EXPECT_LT((a.g - b.g).norm(), tol);
}

TEST(NavState, BoxplusOfBoxminusRecoversTheOtherState) {
  std::mt19937 rng(20);
  for (int t = 0; t < kTrials; ++t) {
    const NavState x = test::random_state(rng);
    const NavState y = test::random_state(rng);  // same |g|, different direction
    expect_states_equal(x.boxplus(y.boxminus(x)), y, 1e-9);
  }
}

TEST(NavState, BoxminusOfBoxplusRecoversTheTangent) {
  std::mt19937 rng(21);
  for (int t = 0; t < kTrials; ++t) {
    const NavState x = test::random_state(rng);
    const StateVector dx = test::random_tangent(rng, 0.5);
    const StateVector back = x.boxplus(dx).boxminus(x);
    EXPECT_LT((back - dx).cwiseAbs().maxCoeff(), 1e-9) << "dx " << dx.transpose() << "\nback " << back.transpose();
  }
}

// Gravity stays on its sphere and the 2-D tangent moves it: δg = (a, 0) turns g by |a| rad.
TEST(NavState, GravityStaysOnTheSphere) {
  std::mt19937 rng(22);
  for (int t = 0; t < kTrials; ++t) {
    const NavState x = test::random_state(rng);
    StateVector dx = StateVector::Zero();
    dx(Idx::kGrav) = 0.3;
    const NavState y = x.boxplus(dx);
    EXPECT_NEAR(y.g.norm(), x.g.norm(), 1e-12);
    EXPECT_NEAR(std::acos(y.g.normalized().dot(x.g.normalized())), 0.3, 1e-9);
    const Eigen::Matrix<double, 3, 2> B = GravityTangentBasis(x.g);
    EXPECT_LT((B.transpose() * B - Eigen::Matrix2d::Identity()).norm(), 1e-12);
    EXPECT_LT((B.transpose() * x.g).norm(), 1e-12);
  }
}

// Each block only moves its own part of the state (the ordering of Idx).
TEST(NavState, BlocksAreIndependent) {
  std::mt19937 rng(23);
  const NavState x = test::random_state(rng);
  for (int i = 0; i < kStateDim; ++i) {
    const StateVector dx = 0.1 * StateVector::Unit(i);
    const StateVector back = x.boxplus(dx).boxminus(x);
    EXPECT_LT((back - dx).norm(), 1e-12) << "index " << i;
  }
}

}  // namespace
}  // namespace fuse

#include "fuse/estimation/ieskf.hpp"

#include <Eigen/Cholesky>
#include <vector>

namespace fuse {

namespace {
/// A variance at or below this is a fixed state dimension (e.g. extrinsic not estimated).
constexpr double kFixedVariance = 1e-24;
}  // namespace

UpdateResult IeskfBackend::update(NavState& x, StateCovariance& P, MeasurementModel& model) {
  UpdateResult result;
  std::vector<int> active;
  for (int i = 0; i < kStateDim; ++i) {
    if (P(i, i) > kFixedVariance) active.push_back(i);
  }
  const int n = static_cast<int>(active.size());
  Eigen::MatrixXd P_a(n, n);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) P_a(r, c) = P(active[r], active[c]);
  }
  const Eigen::MatrixXd P_a_inv = P_a.ldlt().solve(Eigen::MatrixXd::Identity(n, n));

  const NavState prior = x;
  Eigen::MatrixXd A(n, n);
  Eigen::VectorXd b(n);
  LinearSystem sys;
  for (int it = 0; it < config_.max_iterations; ++it) {
    sys = LinearSystem{};
    if (!model.linearize(x, it, sys) || sys.count == 0) break;
    if (it == 0) result.cost_before = sys.cost;
    result.degeneracy = attenuate_degenerate_directions(sys, config_.degeneracy);
    const StateVector e = x.boxminus(prior);
    A = P_a_inv;
    for (int r = 0; r < n; ++r) {
      b(r) = 0.0;
      for (int c = 0; c < n; ++c) b(r) -= P_a_inv(r, c) * e(active[c]);
      if (active[r] < kObsDim) {
        b(r) -= sys.gradient(active[r]);
        for (int c = 0; c < n; ++c) {
          if (active[c] < kObsDim) A(r, c) += sys.information(active[r], active[c]);
        }
      }
    }
    const Eigen::VectorXd delta_a = A.ldlt().solve(b);
    StateVector delta = StateVector::Zero();
    for (int r = 0; r < n; ++r) delta(active[r]) = delta_a(r);
    x = x.boxplus(delta);
    result.updated = true;
    result.iterations = it + 1;
    result.constraints = sys.count;
    result.cost_after = sys.cost;
    if (delta.segment<3>(Idx::kPos).norm() < config_.convergence_translation &&
        delta.segment<3>(Idx::kRot).norm() < config_.convergence_rotation) {
      result.converged = true;
      break;
    }
  }
  if (!result.updated) return result;
  // Posterior covariance P⁺ = (P⁻¹ + Λ')⁻¹ at the last linearisation.
  const Eigen::MatrixXd P_post = A.ldlt().solve(Eigen::MatrixXd::Identity(n, n));
  P.setZero();
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) P(active[r], active[c]) = 0.5 * (P_post(r, c) + P_post(c, r));
  }
  return result;
}

}  // namespace fuse

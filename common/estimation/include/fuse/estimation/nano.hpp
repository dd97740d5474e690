// NANO update (backend "nano", DESIGN §1): a Gaussian q(δx) = N(μ, Λ⁻¹) in the tangent space at
// the prior x̂ (prior N(0, P⁻)), refined by natural-gradient steps on
//   F(q) = KL(q ‖ prior) + E_q[ℓ(x̂ ⊞ δx)],   ℓ = ½ Σ w r²  (−log-likelihood):
//   Λ ← (1−β) Λ + β ((P⁻)⁻¹ + E_q[JᵀWJ]),
//   μ ← μ − β Λ⁻¹ (E_q[∇ℓ] + (P⁻)⁻¹ μ),
// starting from q = prior. E_q[JᵀWJ] is the Gauss-Newton Hessian (the model's Σ w HᵀH), so the
// new Λ is a convex combination of positive definite matrices and stays positive definite;
// E_q[∇ℓ] = E_q[Σ w Hᵀr]. Expectations use the spherical-radial cubature rule over the estimated
// dims of the pose block [δp, δθ] (d ≤ 6): 2d points μ ± √d·L e_i with L Lᵀ = Σ_pose (the marginal
// of Λ⁻¹), equal weights, all other dims at the mean; with cubature off they are taken at the
// mean. The averaged information and gradient are then attenuated along weak directions
// (degeneracy.hpp) like every backend. Jacobians at x̂ ⊞ δ are used as Jacobians in δ (the same
// first-order identification as the IESKF). Stops when KL(q_new ‖ q_old) < kl_tolerance or at
// max_iterations; the posterior is x̂ ⊞ μ with covariance Λ⁻¹.
//
// Adaptive cubature (adaptive_cubature, default on): on an iteration with cubature the step is
// also computed with the expectation at the mean; when the two resulting Gaussians differ by less
// than kl_tolerance (KL), the cubature no longer matters (q is narrow against the model's
// nonlinearity, as for point-to-plane residuals once q is the scan's posterior) and the remaining
// iterations take the mean only, which saves 2d linearisations per iteration.
//
// The mean is linearised first on every iteration with the iteration count (a model may
// re-associate there); cubature points are linearised with kCubatureIteration, past any
// re-association iteration, so a re-associating model only re-screens there. With expectations
// at the mean and β = 1 each step is the IESKF's Gauss-Newton step, so both reach the same fixed
// point (P⁻)⁻¹μ + g(x̂ ⊞ μ) = 0.
#pragma once

#include <functional>

#include "fuse/estimation/update_backend.hpp"

namespace fuse {

/// One NANO iterate over the active dimensions (ActiveSubspace order), for tests and diagnostics.
struct NanoIterate {
  int iteration = 0;
  Eigen::VectorXd mean;       ///< μ after the step
  Eigen::MatrixXd precision;  ///< Λ after the step
  double kl_change = 0.0;     ///< KL(q_new ‖ q_old)
  bool precision_positive_definite = false;  ///< Cholesky of Λ succeeded
};

class NanoBackend final : public UpdateBackend {
 public:
  /// Iteration index passed to the model for cubature points.
  static constexpr int kCubatureIteration = 1 << 20;

  explicit NanoBackend(const UpdateConfig& config) : config_(config) {}
  UpdateResult update(NavState& x, StateCovariance& P, MeasurementModel& model) override;
  std::string name() const override { return "nano"; }
  /// Called after every iteration (debug/test hook).
  void set_iteration_hook(std::function<void(const NanoIterate&)> hook) { hook_ = std::move(hook); }

 private:
  UpdateConfig config_;
  std::function<void(const NanoIterate&)> hook_;
};

}  // namespace fuse

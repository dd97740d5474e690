// Error-state Kalman filter update (backend "eskf"): the EKF's single step on the error state
// δx at the prior (ekf.hpp), then the injection x⁺ = x̂ ⊞ δx and the reset of the error state to
// x⁺'s tangent space, P⁺ ← G P⁺ Gᵀ with G = ∂(δx_new)/∂(δx_old) at δx_old = δx, where δx_new is
// the error of the same true state about x⁺. G is the identity on the vector blocks and, to first
// order in the injected step,
//   rotations (right perturbation, R = R̂ Exp(δθ)):  G_θ = J_r(δθ) ≈ I − ½[δθ]×   (R_WI and R_IL),
//   gravity (g = Exp(B δg) ĝ on S²):                 G_g = B⁺ᵀ (I + ½[B δg]×) B,
// with B and B⁺ the tangent bases at ĝ and g⁺ (the left Jacobian, projected on the new basis).
#pragma once

#include "fuse/estimation/update_backend.hpp"

namespace fuse {

/// The reset Jacobian G for the injection of `delta` into `prior` (block-diagonal, see above).
StateCovariance eskf_reset_jacobian(const NavState& prior, const StateVector& delta);

class EskfBackend final : public UpdateBackend {
 public:
  explicit EskfBackend(const UpdateConfig& config) : config_(config) {}
  UpdateResult update(NavState& x, StateCovariance& P, MeasurementModel& model) override;
  std::string name() const override { return "eskf"; }

 private:
  UpdateConfig config_;
};

}  // namespace fuse

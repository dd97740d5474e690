// Extended Kalman filter update (backend "ekf"): ONE linearisation at the prior, a standard
// Kalman update, no error-state reset. With the prior x̂, P and the (degeneracy-attenuated)
// normal equations Λ' = Σ w HᵀH, g' = Σ w Hᵀr at x̂, the update in information form
//   P⁺ = (P⁻¹ + Λ')⁻¹,   δx = −P⁺ g',   x⁺ = x̂ ⊞ δx
// is algebraically the Kalman gain form K = P Hᵀ(H P Hᵀ + W⁻¹)⁻¹, δx = −K r, P⁺ = (I − K H) P
// (the model hands over normal equations, not H and r). P⁺ is left as computed, i.e. expressed in
// the tangent space at the prior; the ESKF (eskf.hpp) adds the reset to x⁺'s tangent space.
#pragma once

#include "fuse/estimation/update_backend.hpp"

namespace fuse {

/// One information-form Kalman step at the prior shared by the EKF and ESKF: updates x and P as
/// above and returns the step δx (zero when nothing was updated).
StateVector kalman_step(NavState& x, StateCovariance& P, MeasurementModel& model, const DegeneracyConfig& degeneracy,
                        UpdateResult& result);

class EkfBackend final : public UpdateBackend {
 public:
  explicit EkfBackend(const UpdateConfig& config) : config_(config) {}
  UpdateResult update(NavState& x, StateCovariance& P, MeasurementModel& model) override;
  std::string name() const override { return "ekf"; }

 private:
  UpdateConfig config_;
};

}  // namespace fuse

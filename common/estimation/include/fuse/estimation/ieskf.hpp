// Iterated error-state Kalman filter update in information form (as in FAST-LIO2). At iterate
// x_j with e = x_j ⊟ x̂ (x̂, P: the prior) and the linearised constraints (Λ, g = Σ w Hᵀ r):
//   (P⁻¹ + Λ') δ = −P⁻¹ e − g',     x_{j+1} = x_j ⊞ δ,
// with Λ', g' the degeneracy-attenuated information (degeneracy.hpp). At convergence the
// posterior covariance is P⁺ = (P⁻¹ + Λ')⁻¹. Only state dimensions with non-zero prior variance
// are estimated (a fixed extrinsic or gravity has zero variance and stays fixed).
#pragma once

#include "fuse/estimation/update_backend.hpp"

namespace fuse {

class IeskfBackend final : public UpdateBackend {
 public:
  explicit IeskfBackend(const UpdateConfig& config) : config_(config) {}
  UpdateResult update(NavState& x, StateCovariance& P, MeasurementModel& model) override;
  std::string name() const override { return "ieskf"; }

 private:
  UpdateConfig config_;
};

}  // namespace fuse

// Degeneracy-aware update (DESIGN §1): eigen-decompose the pose information
//   Λ = Σ w_j H_jᵀ H_j   (6×6 block over [δp, δθ], rotation scaled by the characteristic length ℓ
// so that both halves are in metres), and attenuate along weak eigen-directions u_i with
//   γ_i = smoothstep((λ_i/λ_max − ρ_lo) / (ρ_hi − ρ_lo)) ∈ [0, 1].
// The INFORMATION (not only the step) is scaled: Λ' = Σ γ_i λ_i u_i u_iᵀ and g' = Σ γ_i (u_iᵀg) u_i,
// so the posterior covariance stays honest (large) along directions the scan does not observe.
#pragma once

#include <Eigen/Core>

#include "fuse/core/config.hpp"
#include "fuse/estimation/measurement_model.hpp"

namespace fuse {

struct DegeneracyConfig {
  bool enabled = true;        ///< ablation switch
  double ratio_low = 0.002;   ///< ρ_lo: at or below this eigenvalue ratio the direction is ignored (γ = 0)
  double ratio_high = 0.02;   ///< ρ_hi: at or above this ratio the direction is fully used (γ = 1)
  void load(ConfigNode& node);
};

struct DegeneracyReport {
  Eigen::Matrix<double, 6, 1> eigenvalues = Eigen::Matrix<double, 6, 1>::Zero();  ///< normalised, ascending
  Eigen::Matrix<double, 6, 1> gamma = Eigen::Matrix<double, 6, 1>::Ones();
  double min_gamma = 1.0;
  double min_ratio = 1.0;  ///< smallest normalised eigenvalue over the largest (1 = isotropic)
  double min_eigenvalue_translation = 0.0;  ///< smallest eigenvalue of the translation block Λ_pp
  double min_eigenvalue_rotation = 0.0;     ///< smallest eigenvalue of the rotation block Λ_θθ
};

/// Analyses `system` and, when enabled, attenuates its pose information and gradient in place.
DegeneracyReport attenuate_degenerate_directions(LinearSystem& system, const DegeneracyConfig& config);

}  // namespace fuse

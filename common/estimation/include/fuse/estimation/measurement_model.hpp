// What an update backend needs from a measurement: linearisation at a state, as the normal
// equations of the whitened residuals over the observed block of the error state.
#pragma once

#include <Eigen/Core>
#include <cstddef>

#include "fuse/estimation/state.hpp"

namespace fuse {

/// The error-state block observed by LiDAR constraints: [δp, δθ, δθ_IL, δp_IL, δt_d] = δx[0:13].
inline constexpr int kObsDim = 13;
using ObsMatrix = Eigen::Matrix<double, kObsDim, kObsDim>;
using ObsVector = Eigen::Matrix<double, kObsDim, 1>;

/// Σ_j w_j H_jᵀH_j and Σ_j w_j H_jᵀ r_j at one linearisation point.
struct LinearSystem {
  ObsMatrix information = ObsMatrix::Zero();  ///< Λ = Σ w HᵀH
  ObsVector gradient = ObsVector::Zero();     ///< Σ w Hᵀ r
  double cost = 0.0;                          ///< Σ w r²
  std::size_t count = 0;                      ///< constraints used
  double characteristic_length = 1.0;         ///< RMS lever arm of the constraints (m), for unit-free rotation/translation comparison
};

class MeasurementModel {
 public:
  virtual ~MeasurementModel() = default;
  /// Linearises at x. `iteration` counts from 0; a model may re-associate on some iterations.
  /// Returns false when there is nothing to update with.
  virtual bool linearize(const NavState& x, int iteration, LinearSystem& out) = 0;
};

}  // namespace fuse

// The LiDAR measurement model: point-to-plane residuals (DESIGN §1)
//   r_j = nᵀ(R_WI (R_IL p_L + p_IL) + p_WI) + d
// with Jacobians over [δp, δθ, δθ_IL, δp_IL] (right perturbations; q = R_IL p_L + p_IL):
//   ∂r/∂δp = nᵀ,  ∂r/∂δθ = (q × R_WIᵀn)ᵀ,  ∂r/∂δθ_IL = (p_L × R_ILᵀR_WIᵀn)ᵀ,  ∂r/∂δp_IL = nᵀR_WI.
// With the LiDAR-IMU time offset estimated, the scan was placed at its stamp plus the offset t_d⁰
// the state had then: a state whose offset is t_d sees the scan at the pose Δ = t_d − t_d⁰ later
// along the motion at the scan end (p + vΔ, R·Exp(ωΔ)), so
//   ∂r/∂δt_d = ∂r/∂δp · v + ∂r/∂δθ · ω,
// a combination of the pose columns, added to the normal equations once per linearisation.
// Associates against the map at the prior and again on later iterations while the pose still moves
// noticeably; otherwise it keeps the planes and only re-screens their residuals.
#pragma once

#include <vector>

#include "fuse/association/associator.hpp"
#include "fuse/core/config.hpp"
#include "fuse/estimation/measurement_model.hpp"

namespace fuse {

/// Jacobian row of one constraint at state x (the observed block). The time offset's column is 0:
/// the state is the pose at the scan's time on the LiDAR clock, which the offset does not move;
/// the offset is seen through the propagation (ReadingChange, imu_propagation.hpp).
Eigen::Matrix<double, 1, kObsDim> point_to_plane_jacobian(const NavState& x, const Constraint& c);
/// Residual of one constraint at state x.
double point_to_plane_residual(const NavState& x, const Constraint& c);

class PointToPlaneModel final : public MeasurementModel {
 public:
  struct Config {
    double point_sigma = 0.05;        ///< m, standard deviation of a point-to-plane residual
    /// Adds the plane fit's RMS to the residual variance: w = 1 / (σ² + rms²), so planes fitted
    /// across edges or steps (a "ramp" through two surfaces) count for less.
    bool weight_by_plane_fit = true;
    int reassociate_iterations = 3;   ///< iterations that may search the map again (then only re-screen)
    double reassociate_translation = 0.05;  ///< m: search again only if the pose moved more than this ...
    double reassociate_rotation = 0.005;    ///< rad: ... or turned more than this since the last search
    bool extrinsic_jacobian = false;  ///< fill the extrinsic columns (when the extrinsic is estimated)
    void load(ConfigNode& node);
  };
  PointToPlaneModel(const Config& config, const std::vector<Eigen::Vector3f>& points_L, const SpatialIndex& map,
                    const Associator& associator, ConstraintSet& constraints)
      : config_(config), points_L_(points_L), map_(map), associator_(associator), constraints_(constraints) {}

  bool linearize(const NavState& x, int iteration, LinearSystem& out) override;
  /// Wall time spent in map association (k-nearest search + plane fits), ms.
  double association_ms() const { return association_ms_; }
  /// Full map searches made so far (the rest of the linearisations only re-screened).
  int searches() const { return searches_; }

 private:
  double association_ms_ = 0.0;
  int searches_ = 0;
  bool associated_ = false;
  Eigen::Isometry3d T_WL_associated_ = Eigen::Isometry3d::Identity();
  Config config_;
  const std::vector<Eigen::Vector3f>& points_L_;
  const SpatialIndex& map_;
  const Associator& associator_;
  ConstraintSet& constraints_;
};

}  // namespace fuse

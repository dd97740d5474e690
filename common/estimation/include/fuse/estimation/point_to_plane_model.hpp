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

/// Jacobian row of one constraint at state x (the observed block; the time offset's column is 0:
/// PointToPlaneModel adds it from the motion it is given).
Eigen::Matrix<double, 1, kObsDim> point_to_plane_jacobian(const NavState& x, const Constraint& c);
/// The state's pose dt later along its motion at constant world velocity x.v and body rate omega:
/// p + v·dt, R·Exp(ω·dt) (where a scan is seen when the time offset moved by dt since placing it).
NavState moved_along(const NavState& x, const Eigen::Vector3d& omega, double dt);
/// Adds the time offset's row and column to normal equations over the pose and extrinsic
/// columns: ∂r/∂δt_d = ∂r/∂δp · v + ∂r/∂δθ · ω for every constraint, so Λ and g follow from the
/// pose block alone (no pass over the constraints).
void add_time_offset_column(LinearSystem& sys, const Eigen::Vector3d& v, const Eigen::Vector3d& omega);
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
  /// Estimates the time offset too: the scan was placed with offset `td_placed`, and the body
  /// moved with world velocity x.v and body rate `omega` (rad/s) at the scan end.
  void set_time_offset_motion(const Eigen::Vector3d& omega, double td_placed) {
    omega_ = omega;
    td_placed_ = td_placed;
    time_offset_ = true;
  }
  /// Wall time spent in map association (k-nearest search + plane fits), ms.
  double association_ms() const { return association_ms_; }

 private:
  double association_ms_ = 0.0;
  bool associated_ = false;
  bool time_offset_ = false;
  Eigen::Vector3d omega_ = Eigen::Vector3d::Zero();
  double td_placed_ = 0.0;
  Eigen::Isometry3d T_WL_associated_ = Eigen::Isometry3d::Identity();
  Config config_;
  const std::vector<Eigen::Vector3f>& points_L_;
  const SpatialIndex& map_;
  const Associator& associator_;
  ConstraintSet& constraints_;
};

}  // namespace fuse

// Per-point motion compensation by querying the temporal state history (DESIGN §1): a point
// measured at t_i is moved to the LiDAR frame at the scan end t_e:
//   p_L(t_e) = T_IL⁻¹ · T_WI(t_e)⁻¹ · T_WI(t_i) · T_IL · p_L(t_i),
// with T_WI(t_i) interpolated on the manifold between the history entries around t_i.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "fuse/core/types.hpp"
#include "fuse/estimation/state_history.hpp"

namespace fuse {

class Deskewer {
 public:
  /// Prepares the relative poses T_WI(t_e)⁻¹·T_WI(t) over [t_start, t_end] from the history.
  /// Returns false when the history does not cover the scan.
  bool prepare(const StateHistory& history, double t_start, double t_end);
  /// Deskews the selected points (indices into scan.points) with the extrinsic T_IL. origins
  /// (optional) receives where the LiDAR was when it measured each point, in the same frame:
  /// the start of the point's ray, T_IL⁻¹ · T_WI(t_e)⁻¹ · T_WI(t_i) · T_IL · 0.
  void apply(const LidarScan& scan, const std::vector<std::uint32_t>& indices, const Eigen::Isometry3d& T_IL,
             std::vector<Eigen::Vector3f>& out, std::vector<Eigen::Vector3f>* origins = nullptr) const;

 private:
  struct Knot {
    double t_rel;            ///< time since scan start
    Eigen::Matrix3d R;       ///< R_e⁻¹ R(t)
    Eigen::Vector3d p;       ///< R_e⁻¹ (p(t) − p_e)
    Eigen::Vector3d omega;   ///< rotation vector to the next knot
  };
  std::vector<Knot> knots_;
};

}  // namespace fuse

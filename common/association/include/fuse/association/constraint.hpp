// Residual-ready point-to-plane constraints (DESIGN §1): for a LiDAR point p_L (deskewed to the
// scan end, LiDAR frame) and a world plane nᵀx + d = 0,
//   r = nᵀ(R_WI (R_IL p_L + p_IL) + p_WI) + d.
#pragma once

#include <Eigen/Core>
#include <vector>

namespace fuse {

struct Constraint {
  Eigen::Vector3f point;   ///< p_L, LiDAR frame at scan end
  Eigen::Vector3f normal;  ///< unit plane normal n (world)
  float d = 0.f;           ///< plane offset
  float quality = 0.f;     ///< q ∈ [0,1], higher is better (screening keeps q ≥ τ_q)
  float residual = 0.f;    ///< r at the state it was associated with
  float plane_rms = 0.f;   ///< RMS distance of the map neighbours to the fitted plane (m)
};

struct ConstraintSet {
  std::vector<Constraint> constraints;
  std::size_t rejected_no_neighbors = 0;  ///< too few map points near the point
  std::size_t rejected_not_planar = 0;    ///< neighbours do not form a plane
  std::size_t rejected_screening = 0;     ///< q < τ_q or |r| > τ_r
  /// Per input point: squared distance to its nearest map point at the last association
  /// (infinity when none within the search radius). The mapping policy reuses it.
  std::vector<float> nearest_dist2;
  void clear() {
    constraints.clear();
    nearest_dist2.clear();
    rejected_no_neighbors = rejected_not_planar = rejected_screening = 0;
  }
  std::size_t rejected() const { return rejected_no_neighbors + rejected_not_planar + rejected_screening; }
};

}  // namespace fuse

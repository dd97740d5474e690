// Local association: a scan's points + the map index + a predicted state -> ConstraintSet.
// Planes are fitted to the k nearest map points (least squares, nᵀq + d = 0); residual screening
// keeps constraints with quality q ≥ τ_q and |r| ≤ τ_r (DESIGN §1).
#pragma once

#include <Eigen/Geometry>

#include "fuse/association/constraint.hpp"
#include "fuse/association/spatial_index.hpp"
#include "fuse/core/config.hpp"

namespace fuse {

struct AssociationConfig {
  int num_neighbors = 5;           ///< k map points per plane
  double max_neighbor_distance = 2.0;  ///< m, farthest neighbour accepted
  double plane_thickness = 0.1;    ///< m, every neighbour within this of the fitted plane
  /// Least share λ₁/λ₂ of the neighbours' scatter (eigenvalues λ₀ ≤ λ₁ ≤ λ₂) across their
  /// longest direction. Below it the neighbours lie along a line (a spinning LiDAR's ring on the
  /// ground, an edge): any plane through the line fits them, and the fitted normal's tilt about
  /// it is set by the noise. Such a neighbourhood is refused (counted as not planar). 0: off
  /// (config/spinning.yaml: 0.05).
  double min_spread_ratio = 0.0;
  bool screening = true;           ///< ablation switch: residual screening on/off
  double min_quality = 0.9;        ///< τ_q
  double max_residual = 0.5;       ///< τ_r, m
  void load(ConfigNode& node);
};

/// Fits nᵀq + d = 0 (|n| = 1) to points by least squares on [q 1]·[n; d] with the smallest
/// eigenvector of their covariance. Returns false when not planar within `thickness`, or when
/// the points spread across their longest direction by less than `min_spread_ratio` of their
/// spread along it (λ₁ < min_spread_ratio·λ₂: a line, AssociationConfig::min_spread_ratio).
/// `rms` (optional) receives the RMS distance of the points to the fitted plane.
bool fit_plane(const Eigen::Vector3f* points, int count, float thickness, Eigen::Vector3f& normal, float& d,
               float* rms = nullptr, float min_spread_ratio = 0.0f);

class Associator {
 public:
  explicit Associator(const AssociationConfig& config) : config_(config) {}
  /// points_L: LiDAR frame points at scan end; T_WL: predicted LiDAR pose in the world.
  void associate(const std::vector<Eigen::Vector3f>& points_L, const Eigen::Isometry3d& T_WL, const SpatialIndex& map,
                 ConstraintSet& out) const;
  /// Recomputes residuals of existing constraints at a new pose and re-applies screening.
  void rescreen(const Eigen::Isometry3d& T_WL, ConstraintSet& set) const;
  const AssociationConfig& config() const { return config_; }

 private:
  bool passes_screening(const Constraint& c) const;
  AssociationConfig config_;
};

}  // namespace fuse

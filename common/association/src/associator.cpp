#include "fuse/association/associator.hpp"

#include "fuse/association/smallest_eigen.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace fuse {

void AssociationConfig::load(ConfigNode& node) {
  node.get("num_neighbors", num_neighbors).get("max_neighbor_distance", max_neighbor_distance);
  node.get("plane_thickness", plane_thickness).get("min_spread_ratio", min_spread_ratio).get("screening", screening);
  node.get("min_quality", min_quality).get("max_residual", max_residual);
  node.check(num_neighbors >= 3 && num_neighbors <= Neighbors::kMaxK, "num_neighbors", "must be in [3, 16]");
  node.check(max_neighbor_distance > 0.0 && max_neighbor_distance < 100.0, "max_neighbor_distance", "must be in (0, 100) m");
  node.check(plane_thickness > 0.0, "plane_thickness", "must be positive");
  node.check(min_spread_ratio >= 0.0 && min_spread_ratio < 1.0, "min_spread_ratio", "must be in [0, 1)");
  node.check(min_quality >= 0.0 && min_quality <= 1.0, "min_quality", "must be in [0, 1]");
  node.check(max_residual > 0.0, "max_residual", "must be positive");
  node.finish();
}

bool fit_plane(const Eigen::Vector3f* points, int count, float thickness, Eigen::Vector3f& normal, float& d,
               float* rms, float min_spread_ratio) {
  if (count < 3) return false;
  // Mean and scatter matrix C = Σ (p − p̄)(p − p̄)ᵀ, its six distinct entries summed in scalars
  // (Eigen's 3×3 outer products cost half of the fit again).
  float sx = 0.0f, sy = 0.0f, sz = 0.0f;
  for (int i = 0; i < count; ++i) {
    sx += points[i].x();
    sy += points[i].y();
    sz += points[i].z();
  }
  const float n = static_cast<float>(count);
  const Eigen::Vector3f mean(sx / n, sy / n, sz / n);
  float xx = 0.0f, xy = 0.0f, xz = 0.0f, yy = 0.0f, yz = 0.0f, zz = 0.0f;
  for (int i = 0; i < count; ++i) {
    const float x = points[i].x() - mean.x(), y = points[i].y() - mean.y(), z = points[i].z() - mean.z();
    xx += x * x;
    xy += x * y;
    xz += x * z;
    yy += y * y;
    yz += y * z;
    zz += z * z;
  }
  Eigen::Matrix3f cov;
  cov << xx, xy, xz, xy, yy, yz, xz, yz, zz;
  // The plane normal is the eigenvector of the smallest eigenvalue (total least squares).
  const SmallestEigen es = smallest_eigen(cov);
  normal = es.vector;
  d = -normal.dot(mean);
  // The smallest eigenvalue of the scatter matrix is the sum of squared distances to the plane.
  if (rms != nullptr) *rms = std::sqrt(std::max(es.values(0), 0.0f) / n);
  // Eigenvalues ascending: λ₁ is the spread across the longest direction λ₂. Points along a line
  // fix only that line; the plane's rotation about it would follow the noise.
  if (min_spread_ratio > 0.0f && es.values(1) < min_spread_ratio * es.values(2)) return false;
  for (int i = 0; i < count; ++i) {
    if (std::abs(normal.dot(points[i]) + d) > thickness) return false;
  }
  return true;
}

bool Associator::passes_screening(const Constraint& c) const {
  if (!config_.screening) return true;
  return c.quality >= config_.min_quality && std::abs(c.residual) <= config_.max_residual;
}

namespace {
/// Quality of a point-to-plane match: q = 1 − 0.9·|r|/√‖p_L‖ (residuals large for the point's
/// range are less trustworthy; the heuristic of FAST-LIO2's plane screening), clamped to [0, 1].
float match_quality(float residual, const Eigen::Vector3f& p_L) {
  const float range = std::max(p_L.norm(), 1e-3f);
  return std::clamp(1.0f - 0.9f * std::abs(residual) / std::sqrt(range), 0.0f, 1.0f);
}
}  // namespace

void Associator::associate(const std::vector<Eigen::Vector3f>& points_L, const Eigen::Isometry3d& T_WL,
                           const SpatialIndex& map, ConstraintSet& out) const {
  out.clear();
  out.constraints.reserve(points_L.size());
  out.nearest_dist2.resize(points_L.size());
  const Eigen::Matrix3f R = T_WL.linear().cast<float>();
  const Eigen::Vector3f t = T_WL.translation().cast<float>();
  const float max_dist = static_cast<float>(config_.max_neighbor_distance);
  const float thickness = static_cast<float>(config_.plane_thickness);
  const float min_spread = static_cast<float>(config_.min_spread_ratio);
  Neighbors nb;
  for (std::size_t i = 0; i < points_L.size(); ++i) {
    const Eigen::Vector3f& p_L = points_L[i];
    const Eigen::Vector3f p_W = R * p_L + t;
    map.knn(p_W, config_.num_neighbors, max_dist, nb);
    out.nearest_dist2[i] = nb.count > 0 ? nb.dist2[0] : std::numeric_limits<float>::infinity();
    if (nb.count < config_.num_neighbors) {
      ++out.rejected_no_neighbors;
      continue;
    }
    Constraint c;
    if (!fit_plane(nb.points, nb.count, thickness, c.normal, c.d, &c.plane_rms, min_spread)) {
      ++out.rejected_not_planar;
      continue;
    }
    c.point = p_L;
    c.residual = c.normal.dot(p_W) + c.d;
    c.quality = match_quality(c.residual, p_L);
    if (!passes_screening(c)) {
      ++out.rejected_screening;
      continue;
    }
    out.constraints.push_back(c);
  }
}

void Associator::rescreen(const Eigen::Isometry3d& T_WL, ConstraintSet& set) const {
  const Eigen::Matrix3f R = T_WL.linear().cast<float>();
  const Eigen::Vector3f t = T_WL.translation().cast<float>();
  std::size_t kept = 0;
  for (Constraint& c : set.constraints) {
    c.residual = c.normal.dot(R * c.point + t) + c.d;
    c.quality = match_quality(c.residual, c.point);
    if (passes_screening(c)) {
      set.constraints[kept++] = c;
    } else {
      ++set.rejected_screening;
    }
  }
  set.constraints.resize(kept);
}

}  // namespace fuse

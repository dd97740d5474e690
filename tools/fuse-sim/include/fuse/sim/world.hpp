// Analytic worlds: solid axis-aligned boxes and infinite planes, each with a surface id and a
// reflectivity. Rays are cast against the boxes through a BVH and against the planes directly.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <vector>

#include "fuse/sim/bvh.hpp"

namespace fuse::sim {

/// What a surface looks like to the LiDAR.
struct Material {
  std::uint16_t surface_id = 0;  ///< e.g. wall, floor, door jamb (scenario specific)
  double reflectivity = 0.5;     ///< in (0, 1]
};

/// A solid axis-aligned box [min, max].
struct Box {
  Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();
  Material material;
};

/// The infinite plane n . x = offset (|n| = 1); it blocks rays from both sides.
struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double offset = 0.0;
  Material material;
};

/// The first surface along a ray.
struct Hit {
  double range = std::numeric_limits<double>::infinity();  ///< metres along the unit direction
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();        ///< surface normal facing the ray
  Material material;
  bool valid() const { return range < std::numeric_limits<double>::infinity(); }
};

/// Analytic ray-box intersection (slab method). A ray starting inside the box hits at range 0.
Hit intersect(const Box& box, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir);
/// Analytic ray-plane intersection: t = (offset - n . o) / (n . d) when t >= 0.
Hit intersect(const Plane& plane, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir);

class World {
 public:
  void add(const Box& box);
  void add(const Plane& plane);
  /// Builds the acceleration structure; call once after the last add() and before cast().
  void build();

  /// Closest hit of the ray origin + t dir (dir unit length), t in [0, max_range].
  Hit cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double max_range) const;
  /// The same by testing every primitive (reference for tests).
  Hit cast_brute_force(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double max_range) const;
  /// Euclidean distance from p to the nearest solid (0 inside a box); brute force, for checks.
  double clearance(const Eigen::Vector3d& p) const;
  /// The same when it is at most `radius`, otherwise +inf: only the boxes the BVH finds within
  /// radius of p are measured (fast, e.g. for classifying a million map points). Needs build().
  double clearance_within(const Eigen::Vector3d& p, double radius) const;

  const std::vector<Box>& boxes() const { return boxes_; }
  const std::vector<Plane>& planes() const { return planes_; }

 private:
  std::vector<Box> boxes_;
  std::vector<Plane> planes_;
  Bvh bvh_;
  bool built_ = false;
};

}  // namespace fuse::sim

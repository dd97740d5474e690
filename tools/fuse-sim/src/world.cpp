#include "fuse/sim/world.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace fuse::sim {

Hit intersect(const Box& box, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  // Slab method: the ray is inside slab a for t in [(min_a - o_a)/d_a, (max_a - o_a)/d_a].
  double t_near = -std::numeric_limits<double>::infinity(), t_far = std::numeric_limits<double>::infinity();
  int near_axis = -1;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0.0) {
      if (o[a] < box.min[a] || o[a] > box.max[a]) return {};
      continue;
    }
    double t0 = (box.min[a] - o[a]) / d[a], t1 = (box.max[a] - o[a]) / d[a];
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > t_near) {
      t_near = t0;
      near_axis = a;
    }
    t_far = std::min(t_far, t1);
  }
  if (t_near > t_far || t_far < 0.0) return {};
  Hit hit;
  hit.material = box.material;
  if (t_near < 0.0 || near_axis < 0) {  // the origin is inside the solid: blocked at once
    hit.range = 0.0;
    hit.normal = -d;
    return hit;
  }
  hit.range = t_near;
  hit.normal[near_axis] = d[near_axis] > 0.0 ? -1.0 : 1.0;
  return hit;
}

Hit intersect(const Plane& plane, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  const double denom = plane.normal.dot(d);
  if (denom == 0.0) return {};
  const double t = (plane.offset - plane.normal.dot(o)) / denom;
  if (!(t >= 0.0)) return {};
  Hit hit;
  hit.range = t;
  hit.normal = denom < 0.0 ? plane.normal : Eigen::Vector3d(-plane.normal);
  hit.material = plane.material;
  return hit;
}

void World::add(const Box& box) {
  if (!(box.min.array() < box.max.array()).all() || !box.min.allFinite() || !box.max.allFinite())
    throw std::invalid_argument("world: a box needs finite min < max on every axis");
  boxes_.push_back(box);
  built_ = false;
}

void World::add(const Plane& plane) {
  if (std::abs(plane.normal.norm() - 1.0) > 1e-9) throw std::invalid_argument("world: plane normal not unit");
  planes_.push_back(plane);
}

void World::build() {
  std::vector<Eigen::Vector3d> mins, maxs;
  for (const Box& b : boxes_) {
    mins.push_back(b.min);
    maxs.push_back(b.max);
  }
  bvh_.build(mins, maxs);
  built_ = true;
}

Hit World::cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double max_range) const {
  if (!built_) throw std::logic_error("world: cast() before build()");
  Hit best;
  for (const Plane& p : planes_) {
    const Hit h = intersect(p, o, d);
    if (h.range < best.range) best = h;
  }
  bvh_.traverse(o, d, std::min(max_range, best.range), [&](std::uint32_t i, double range) {
    const Hit h = intersect(boxes_[i], o, d);
    if (h.range < best.range) best = h;
    return std::min(range, best.range);
  });
  if (best.range > max_range) return {};
  return best;
}

Hit World::cast_brute_force(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double max_range) const {
  Hit best;
  for (const Plane& p : planes_) {
    const Hit h = intersect(p, o, d);
    if (h.range < best.range) best = h;
  }
  for (const Box& b : boxes_) {
    const Hit h = intersect(b, o, d);
    if (h.range < best.range) best = h;
  }
  if (best.range > max_range) return {};
  return best;
}

double World::clearance(const Eigen::Vector3d& p) const {
  double best = std::numeric_limits<double>::infinity();
  for (const Plane& pl : planes_) best = std::min(best, std::abs(pl.normal.dot(p) - pl.offset));
  for (const Box& b : boxes_) {
    const Eigen::Vector3d outside = (b.min - p).cwiseMax(p - b.max).cwiseMax(0.0);
    best = std::min(best, outside.norm());
  }
  return best;
}

double World::clearance_within(const Eigen::Vector3d& p, double radius) const {
  if (!built_) throw std::logic_error("world: clearance_within() before build()");
  double best = std::numeric_limits<double>::infinity();
  for (const Plane& pl : planes_) best = std::min(best, std::abs(pl.normal.dot(p) - pl.offset));
  const Eigen::Vector3d r = Eigen::Vector3d::Constant(radius);
  bvh_.overlapping(p - r, p + r, [&](std::uint32_t i) {
    const Box& b = boxes_[i];
    const Eigen::Vector3d outside = (b.min - p).cwiseMax(p - b.max).cwiseMax(0.0);
    best = std::min(best, outside.norm());
  });
  return best <= radius ? best : std::numeric_limits<double>::infinity();
}

}  // namespace fuse::sim

// Bounding volume hierarchy over axis-aligned boxes: binary tree split at the median centroid of
// the longest axis, small leaves, closest-hit traversal visiting the nearer child first.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <algorithm>
#include <vector>

namespace fuse::sim {

class Bvh {
 public:
  /// Builds over the boxes [mins[i], maxs[i]].
  void build(const std::vector<Eigen::Vector3d>& mins, const std::vector<Eigen::Vector3d>& maxs);

  /// Visits the primitives whose bounds the ray meets before the current best range; the visitor
  /// tests primitive i and returns the (possibly smaller) best range so far.
  template <typename Visitor>
  void traverse(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double max_range, Visitor&& visit) const;

  /// Visits every primitive i whose bounds overlap the box [lo, hi] (e.g. a point's neighbourhood).
  template <typename Visitor>
  void overlapping(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, Visitor&& visit) const;

 private:
  struct Node {
    Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();
    std::uint32_t first = 0;  ///< leaf: first index into order_; inner: right child index
    std::uint32_t count = 0;  ///< leaf: number of primitives; inner: 0 (left child follows)
  };
  std::uint32_t build_node(std::uint32_t begin, std::uint32_t end);
  /// Slab test of the ray against [lo, hi]: entry distance, or +inf when missed or beyond t_max.
  /// NaN from 0 * inf (origin on a slab plane, ray parallel) is ignored by the max/min order.
  static double slab_entry(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Eigen::Vector3d& o,
                           const Eigen::Vector3d& inv, double t_max) {
    double t0 = 0.0, t1 = t_max;
    for (int a = 0; a < 3; ++a) {
      const double n = (lo[a] - o[a]) * inv[a], f = (hi[a] - o[a]) * inv[a];
      t0 = std::max(t0, std::min(n, f));
      t1 = std::min(t1, std::max(n, f));
    }
    return t0 <= t1 ? t0 : kMiss;
  }
  static constexpr double kMiss = 1e300;
  static constexpr int kMaxDepth = 64;  ///< traversal stack (the median split keeps depth ~log2 n)

  std::vector<Node> nodes_;
  std::vector<std::uint32_t> order_;
  std::vector<Eigen::Vector3d> mins_, maxs_;
};

template <typename Visitor>
void Bvh::traverse(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double max_range, Visitor&& visit) const {
  if (nodes_.empty()) return;
  const Eigen::Vector3d inv = dir.cwiseInverse();
  double best = max_range;
  std::uint32_t stack[kMaxDepth];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const std::uint32_t index = stack[--top];
    const Node& node = nodes_[index];
    if (slab_entry(node.min, node.max, origin, inv, best) > best) continue;
    if (node.count > 0) {
      for (std::uint32_t i = node.first; i < node.first + node.count; ++i) best = visit(order_[i], best);
      continue;
    }
    const std::uint32_t left = index + 1, right = node.first;
    const double tl = slab_entry(nodes_[left].min, nodes_[left].max, origin, inv, best);
    const double tr = slab_entry(nodes_[right].min, nodes_[right].max, origin, inv, best);
    // Push the farther child first so the nearer one is visited first.
    const bool left_first = tl <= tr;
    const std::uint32_t first = left_first ? right : left, second = left_first ? left : right;
    const double t_first = left_first ? tr : tl, t_second = left_first ? tl : tr;
    if (t_first <= best) stack[top++] = first;
    if (t_second <= best) stack[top++] = second;
  }
}

template <typename Visitor>
void Bvh::overlapping(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, Visitor&& visit) const {
  if (nodes_.empty()) return;
  std::uint32_t stack[kMaxDepth];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const std::uint32_t index = stack[--top];
    const Node& node = nodes_[index];
    if ((node.min.array() > hi.array()).any() || (node.max.array() < lo.array()).any()) continue;
    if (node.count > 0) {
      for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
        const std::uint32_t k = order_[i];
        if ((mins_[k].array() <= hi.array()).all() && (maxs_[k].array() >= lo.array()).all()) visit(k);
      }
      continue;
    }
    stack[top++] = node.first;  // right child
    stack[top++] = index + 1;   // left child
  }
}

}  // namespace fuse::sim

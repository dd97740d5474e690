#include "fuse/sim/bvh.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace fuse::sim {

namespace {
constexpr std::uint32_t kLeafSize = 4;  // primitives per leaf
constexpr int kMaxDepth = 64;           // traversal stack size (the median split keeps depth ~log2 n)

// Slab test against [lo, hi]; returns the entry distance or +inf when missed (or beyond t_max).
double slab_entry(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Eigen::Vector3d& o,
                  const Eigen::Vector3d& inv, double t_max) {
  double t0 = 0.0, t1 = t_max;
  for (int a = 0; a < 3; ++a) {
    double near = (lo[a] - o[a]) * inv[a], far = (hi[a] - o[a]) * inv[a];
    if (near > far) std::swap(near, far);
    if (std::isnan(near)) near = -std::numeric_limits<double>::infinity();  // o on a slab, dir parallel
    if (std::isnan(far)) far = std::numeric_limits<double>::infinity();
    t0 = std::max(t0, near);
    t1 = std::min(t1, far);
    if (t0 > t1) return std::numeric_limits<double>::infinity();
  }
  return t0;
}
}  // namespace

void Bvh::build(const std::vector<Eigen::Vector3d>& mins, const std::vector<Eigen::Vector3d>& maxs) {
  mins_ = mins;
  maxs_ = maxs;
  nodes_.clear();
  order_.resize(mins.size());
  for (std::uint32_t i = 0; i < order_.size(); ++i) order_[i] = i;
  if (!order_.empty()) build_node(0, static_cast<std::uint32_t>(order_.size()));
}

std::uint32_t Bvh::build_node(std::uint32_t begin, std::uint32_t end) {
  const std::uint32_t index = static_cast<std::uint32_t>(nodes_.size());
  nodes_.push_back({});
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  Eigen::Vector3d clo = lo, chi = hi;  // centroid bounds
  for (std::uint32_t i = begin; i < end; ++i) {
    const std::uint32_t k = order_[i];
    lo = lo.cwiseMin(mins_[k]);
    hi = hi.cwiseMax(maxs_[k]);
    const Eigen::Vector3d c = 0.5 * (mins_[k] + maxs_[k]);
    clo = clo.cwiseMin(c);
    chi = chi.cwiseMax(c);
  }
  nodes_[index].min = lo;
  nodes_[index].max = hi;
  if (end - begin <= kLeafSize) {
    nodes_[index].first = begin;
    nodes_[index].count = end - begin;
    return index;
  }
  int axis = 0;
  (chi - clo).maxCoeff(&axis);
  const std::uint32_t mid = begin + (end - begin) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](std::uint32_t a, std::uint32_t b) {
                     return mins_[a][axis] + maxs_[a][axis] < mins_[b][axis] + maxs_[b][axis];
                   });
  build_node(begin, mid);  // left child is index + 1
  const std::uint32_t right = build_node(mid, end);
  nodes_[index].first = right;
  nodes_[index].count = 0;
  return index;
}

void Bvh::traverse(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double max_range,
                   const std::function<double(std::uint32_t, double)>& visit) const {
  if (nodes_.empty()) return;
  const Eigen::Vector3d inv = dir.cwiseInverse();
  double best = max_range;
  std::uint32_t stack[kMaxDepth];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (slab_entry(node.min, node.max, origin, inv, best) > best) continue;
    if (node.count > 0) {
      for (std::uint32_t i = node.first; i < node.first + node.count; ++i) best = visit(order_[i], best);
      continue;
    }
    const std::uint32_t left = static_cast<std::uint32_t>(&node - nodes_.data()) + 1, right = node.first;
    const double tl = slab_entry(nodes_[left].min, nodes_[left].max, origin, inv, best);
    const double tr = slab_entry(nodes_[right].min, nodes_[right].max, origin, inv, best);
    // Push the farther child first so the nearer one is visited first.
    if (tl <= tr) {
      if (tr <= best) stack[top++] = right;
      if (tl <= best) stack[top++] = left;
    } else {
      if (tl <= best) stack[top++] = left;
      if (tr <= best) stack[top++] = right;
    }
  }
}

}  // namespace fuse::sim

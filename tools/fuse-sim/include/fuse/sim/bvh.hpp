// Bounding volume hierarchy over axis-aligned boxes: binary tree split at the median centroid of
// the longest axis, small leaves, closest-hit traversal visiting the nearer child first.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <vector>

namespace fuse::sim {

class Bvh {
 public:
  /// Builds over the boxes [mins[i], maxs[i]].
  void build(const std::vector<Eigen::Vector3d>& mins, const std::vector<Eigen::Vector3d>& maxs);

  /// Visits the primitives whose bounds the ray meets before the current best range; the visitor
  /// tests primitive i and returns the (possibly smaller) best range so far.
  void traverse(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double max_range,
                const std::function<double(std::uint32_t, double)>& visit) const;

 private:
  struct Node {
    Eigen::Vector3d min = Eigen::Vector3d::Zero(), max = Eigen::Vector3d::Zero();
    std::uint32_t first = 0;  ///< leaf: first index into order_; inner: right child index
    std::uint32_t count = 0;  ///< leaf: number of primitives; inner: 0 (left child follows)
  };
  std::uint32_t build_node(std::uint32_t begin, std::uint32_t end);

  std::vector<Node> nodes_;
  std::vector<std::uint32_t> order_;
  std::vector<Eigen::Vector3d> mins_, maxs_;
};

}  // namespace fuse::sim

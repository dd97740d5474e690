// Incremental kd-tree (type "kdtree"): exact k-nearest search for a map that grows every scan.
//
// Design (in the spirit of the ikd-tree of FAST-LIO2, with bucket leaves):
//  * One tree. Internal nodes split on the widest axis of their points at the median; leaves hold
//    up to kLeafSize points (more only when all of them coincide). Every node keeps the tight
//    bounding box and the count of the points below it. Search correctness relies only on the
//    boxes, never on the split planes, so a point may sit on either side of its split value.
//  * Insert descends by the split values, grows the boxes and counts on the way and appends the
//    point to a leaf; a leaf past kMaxLeafSize is rebuilt into a small balanced subtree.
//  * Scapegoat rebalancing: after every chunk of inserts (and after trim), the subtrees touched
//    are checked top-down; a node whose larger child holds more than kAlpha of its points is
//    rebuilt from scratch (median splits). A subtree of m points is rebuilt only after Θ(m)
//    inserts below it, so inserts cost O(log² n) amortised and the depth stays O(log n).
//    A batch at least as large as the tree rebuilds it whole (cheaper than inserting).
//  * knn: depth-first, nearer child first, pruning every node whose box is farther than the
//    current k-th neighbour (or max_dist). Exact.
//  * trim: subtrees whose box is inside the kept box stay untouched, those outside it are
//    freed whole, leaves on the border are filtered; emptied nodes are spliced out, boxes and
//    counts recomputed, then the same rebalancing runs. erase prunes the same way, descending
//    only into the boxes that contain the point.
// Nodes live in one vector (indices, not pointers) with a free list.
#pragma once

#include <cstdint>
#include <vector>

#include "fuse/association/spatial_index.hpp"

namespace fuse {

class KdTreeIndex final : public SpatialIndex {
 public:
  explicit KdTreeIndex(const SpatialIndexConfig& config);

  void insert(const std::vector<Eigen::Vector3f>& world_points) override;
  void knn(const Eigen::Vector3f& q, int k, float max_dist, Neighbors& out) const override;
  void trim(const Eigen::Vector3f& center, float half_extent) override;
  std::size_t erase(const std::vector<Eigen::Vector3f>& points) override;
  std::size_t size() const override { return root_ < 0 ? 0 : nodes_[static_cast<std::size_t>(root_)].count; }
  void for_each_point(const std::function<void(const Eigen::Vector3f&)>& fn) const override;
  std::string name() const override { return "kdtree"; }

  /// Longest root-to-leaf path (1 for a single leaf, 0 when empty); for tests of the balancing.
  int depth() const;

 private:
  struct Node {
    Eigen::Vector3f lo, hi;  ///< tight bounding box of the subtree's points
    std::uint32_t count = 0;
    std::int32_t left = -1, right = -1;  ///< -1: leaf
    float split = 0.0f;
    std::int32_t axis = 0;
    bool dirty = false;  ///< received inserts/removals since the last rebalancing check
    std::vector<Eigen::Vector3f> points;  ///< leaves only
    bool leaf() const { return left < 0; }
  };

  std::int32_t alloc_node();
  void free_subtree(std::int32_t idx);
  /// Appends the subtree's points to out and frees every node below idx (idx becomes an empty leaf).
  void collect(std::int32_t idx, std::vector<Eigen::Vector3f>& out);
  /// Makes idx a balanced subtree over [begin, end) (non-empty).
  void build(std::int32_t idx, Eigen::Vector3f* begin, Eigen::Vector3f* end);
  void rebuild(std::int32_t idx);
  void insert_point(const Eigen::Vector3f& p);
  void rebalance(std::int32_t idx);
  /// Removes the points `drop` selects from the subtree at idx: a subtree whose box `untouched`
  /// says holds none is skipped, one that `all_dropped` says holds only such points is freed
  /// whole; emptied nodes are spliced out, boxes and counts recomputed. Returns the number of
  /// points left under idx; idx is freed when that is 0. (trim and erase.)
  template <class Untouched, class AllDropped, class Drop>
  std::uint32_t prune(std::int32_t idx, const Untouched& untouched, const AllDropped& all_dropped, const Drop& drop);
  /// prune from the root, then the rebalancing check.
  template <class Untouched, class AllDropped, class Drop>
  void prune_root(const Untouched& untouched, const AllDropped& all_dropped, const Drop& drop);
  void search(std::int32_t idx, const Eigen::Vector3f& q, int k, float& bound2, Neighbors& out) const;
  int depth(std::int32_t idx) const;

  std::vector<Node> nodes_;
  std::vector<std::int32_t> free_nodes_;
  std::int32_t root_ = -1;
  std::vector<Eigen::Vector3f> scratch_;
};

}  // namespace fuse

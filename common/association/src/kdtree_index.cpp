#include "fuse/association/kdtree_index.hpp"

#include <algorithm>
#include <limits>

namespace fuse {

namespace {
/// A leaf built by build() holds at most kLeafSize points; inserts may grow it to kMaxLeafSize.
constexpr std::size_t kLeafSize = 16;
constexpr std::size_t kMaxLeafSize = 2 * kLeafSize;
/// A subtree is rebuilt when its larger child holds more than this fraction of its points…
constexpr double kAlpha = 0.8;
/// …and it holds at least this many (smaller subtrees are cheap to search anyway).
constexpr std::uint32_t kMinBalanceCount = 8 * kLeafSize;
/// Inserts are checked for balance after every chunk of this many points.
constexpr std::size_t kInsertChunk = 1024;

/// Squared distance from q to the box [lo, hi] (0 inside), computed so that it never exceeds
/// (p − q).squaredNorm() for a point p of the box (float subtraction is monotone).
inline float box_dist2(const Eigen::Vector3f& q, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) {
  return (lo - q).cwiseMax(q - hi).cwiseMax(0.0f).squaredNorm();
}

/// Keeps the k best in out (sorted ascending); returns the new pruning bound.
inline void offer(const Eigen::Vector3f& p, float d2, int k, float& bound2, Neighbors& out) {
  int pos = out.count < k ? out.count++ : k - 1;
  while (pos > 0 && out.dist2[pos - 1] > d2) {
    out.dist2[pos] = out.dist2[pos - 1];
    out.points[pos] = out.points[pos - 1];
    --pos;
  }
  out.dist2[pos] = d2;
  out.points[pos] = p;
  if (out.count == k) bound2 = out.dist2[k - 1];
}

/// True when every point of [lo, hi] passes the trim test |p − c| ≤ h on every axis (the same
/// float expression as the per-point test, which is monotone in p).
inline bool box_inside(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, const Eigen::Vector3f& c, float h) {
  return ((lo - c).cwiseAbs().array() <= h).all() && ((hi - c).cwiseAbs().array() <= h).all();
}
/// True when no point of [lo, hi] passes the trim test.
inline bool box_outside(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi, const Eigen::Vector3f& c, float h) {
  return ((lo - c).array() > h).any() || ((hi - c).array() < -h).any();
}
inline bool point_outside(const Eigen::Vector3f& p, const Eigen::Vector3f& c, float h) {
  return ((p - c).cwiseAbs().array() > h).any();
}
}  // namespace

KdTreeIndex::KdTreeIndex(const SpatialIndexConfig& /*config*/) {}

std::int32_t KdTreeIndex::alloc_node() {
  if (!free_nodes_.empty()) {
    const std::int32_t idx = free_nodes_.back();
    free_nodes_.pop_back();
    return idx;
  }
  nodes_.emplace_back();
  return static_cast<std::int32_t>(nodes_.size() - 1);
}

void KdTreeIndex::free_subtree(std::int32_t idx) {
  Node& n = nodes_[static_cast<std::size_t>(idx)];
  if (!n.leaf()) {
    const std::int32_t l = n.left, r = n.right;
    free_subtree(l);
    free_subtree(r);
  }
  Node& m = nodes_[static_cast<std::size_t>(idx)];
  m.points.clear();
  m.left = m.right = -1;
  m.count = 0;
  m.dirty = false;
  free_nodes_.push_back(idx);
}

void KdTreeIndex::collect(std::int32_t idx, std::vector<Eigen::Vector3f>& out) {
  Node& n = nodes_[static_cast<std::size_t>(idx)];
  if (n.leaf()) {
    out.insert(out.end(), n.points.begin(), n.points.end());
    n.points.clear();
  } else {
    const std::int32_t l = n.left, r = n.right;
    collect(l, out);
    collect(r, out);
    free_nodes_.push_back(l);
    free_nodes_.push_back(r);
    nodes_[static_cast<std::size_t>(l)].left = nodes_[static_cast<std::size_t>(l)].right = -1;
    nodes_[static_cast<std::size_t>(r)].left = nodes_[static_cast<std::size_t>(r)].right = -1;
  }
  Node& m = nodes_[static_cast<std::size_t>(idx)];
  m.left = m.right = -1;
  m.count = 0;
  m.dirty = false;
}

void KdTreeIndex::build(std::int32_t idx, Eigen::Vector3f* begin, Eigen::Vector3f* end) {
  const std::size_t n = static_cast<std::size_t>(end - begin);
  Eigen::Vector3f lo = *begin, hi = *begin;
  for (const Eigen::Vector3f* p = begin + 1; p != end; ++p) {
    lo = lo.cwiseMin(*p);
    hi = hi.cwiseMax(*p);
  }
  {
    Node& node = nodes_[static_cast<std::size_t>(idx)];
    node.lo = lo;
    node.hi = hi;
    node.count = static_cast<std::uint32_t>(n);
    node.dirty = false;
    node.left = node.right = -1;
    node.points.clear();
  }
  Eigen::Vector3f::Index axis = 0;
  const float extent = (hi - lo).maxCoeff(&axis);
  if (n <= kLeafSize || !(extent > 0.0f)) {
    nodes_[static_cast<std::size_t>(idx)].points.assign(begin, end);
    return;
  }
  Eigen::Vector3f* mid = begin + n / 2;
  const int a = static_cast<int>(axis);
  std::nth_element(begin, mid, end, [a](const Eigen::Vector3f& x, const Eigen::Vector3f& y) { return x[a] < y[a]; });
  const std::int32_t l = alloc_node();
  const std::int32_t r = alloc_node();  // may reallocate nodes_: index again below
  Node& node = nodes_[static_cast<std::size_t>(idx)];
  node.axis = a;
  node.split = (*mid)[a];
  node.left = l;
  node.right = r;
  build(l, begin, mid);
  build(r, mid, end);
}

void KdTreeIndex::rebuild(std::int32_t idx) {
  scratch_.clear();
  collect(idx, scratch_);
  if (scratch_.empty()) return;
  build(idx, scratch_.data(), scratch_.data() + scratch_.size());
}

void KdTreeIndex::insert_point(const Eigen::Vector3f& p) {
  std::int32_t idx = root_;
  for (;;) {
    Node& n = nodes_[static_cast<std::size_t>(idx)];
    n.lo = n.lo.cwiseMin(p);
    n.hi = n.hi.cwiseMax(p);
    ++n.count;
    n.dirty = true;
    if (n.leaf()) {
      n.points.push_back(p);
      if (n.points.size() > kMaxLeafSize && (n.hi - n.lo).maxCoeff() > 0.0f) rebuild(idx);
      return;
    }
    idx = p[n.axis] < n.split ? n.left : n.right;
  }
}

void KdTreeIndex::rebalance(std::int32_t idx) {
  Node& n = nodes_[static_cast<std::size_t>(idx)];
  if (!n.dirty) return;
  n.dirty = false;
  if (n.leaf()) return;
  const std::uint32_t larger =
      std::max(nodes_[static_cast<std::size_t>(n.left)].count, nodes_[static_cast<std::size_t>(n.right)].count);
  if (n.count >= kMinBalanceCount && static_cast<double>(larger) > kAlpha * static_cast<double>(n.count)) {
    rebuild(idx);
    return;
  }
  const std::int32_t l = n.left, r = n.right;
  rebalance(l);
  rebalance(r);
}

void KdTreeIndex::insert(const std::vector<Eigen::Vector3f>& world_points) {
  if (world_points.empty()) return;
  if (world_points.size() >= size()) {
    // Bulk: one balanced build over the old and new points.
    scratch_.clear();
    if (root_ >= 0) {
      collect(root_, scratch_);
    } else {
      root_ = alloc_node();
    }
    scratch_.insert(scratch_.end(), world_points.begin(), world_points.end());
    build(root_, scratch_.data(), scratch_.data() + scratch_.size());
    return;
  }
  for (std::size_t i = 0; i < world_points.size(); ++i) {
    insert_point(world_points[i]);
    if ((i + 1) % kInsertChunk == 0 || i + 1 == world_points.size()) rebalance(root_);
  }
}

void KdTreeIndex::search(std::int32_t idx, const Eigen::Vector3f& q, int k, float& bound2, Neighbors& out) const {
  const Node& n = nodes_[static_cast<std::size_t>(idx)];
  if (n.leaf()) {
    for (const Eigen::Vector3f& p : n.points) {
      const float d2 = (p - q).squaredNorm();
      if (d2 <= bound2) offer(p, d2, k, bound2, out);
    }
    return;
  }
  const Node& l = nodes_[static_cast<std::size_t>(n.left)];
  const Node& r = nodes_[static_cast<std::size_t>(n.right)];
  const float dl = box_dist2(q, l.lo, l.hi);
  const float dr = box_dist2(q, r.lo, r.hi);
  const bool left_first = dl <= dr;
  const std::int32_t first = left_first ? n.left : n.right, second = left_first ? n.right : n.left;
  const float d_first = left_first ? dl : dr, d_second = left_first ? dr : dl;
  if (d_first <= bound2) search(first, q, k, bound2, out);
  if (d_second <= bound2) search(second, q, k, bound2, out);
}

void KdTreeIndex::knn(const Eigen::Vector3f& q, int k, float max_dist, Neighbors& out) const {
  k = std::min(k, Neighbors::kMaxK);
  out.count = 0;
  if (root_ < 0 || k <= 0) return;
  float bound2 = max_dist * max_dist;
  const Node& root = nodes_[static_cast<std::size_t>(root_)];
  if (box_dist2(q, root.lo, root.hi) > bound2) return;
  search(root_, q, k, bound2, out);
}

template <class Untouched, class AllDropped, class Drop>
std::uint32_t KdTreeIndex::prune(std::int32_t idx, const Untouched& untouched, const AllDropped& all_dropped,
                                 const Drop& drop) {
  Node& n = nodes_[static_cast<std::size_t>(idx)];
  if (untouched(n.lo, n.hi)) return n.count;
  if (all_dropped(n.lo, n.hi)) {
    free_subtree(idx);
    return 0;
  }
  if (n.leaf()) {
    auto& pts = n.points;
    pts.erase(std::remove_if(pts.begin(), pts.end(), drop), pts.end());
    if (pts.empty()) {
      free_subtree(idx);
      return 0;
    }
    if (pts.size() != n.count) n.dirty = true;
    n.count = static_cast<std::uint32_t>(pts.size());
    n.lo = n.hi = pts.front();
    for (const Eigen::Vector3f& p : pts) {
      n.lo = n.lo.cwiseMin(p);
      n.hi = n.hi.cwiseMax(p);
    }
    return n.count;
  }
  const std::int32_t l = n.left, r = n.right;
  const std::uint32_t nl = prune(l, untouched, all_dropped, drop);
  const std::uint32_t nr = prune(r, untouched, all_dropped, drop);
  if (nl == 0 && nr == 0) {
    Node& m = nodes_[static_cast<std::size_t>(idx)];
    m.left = m.right = -1;  // children already freed
    free_subtree(idx);
    return 0;
  }
  if (nl == 0 || nr == 0) {
    // Splice the surviving child into this node's slot.
    const std::int32_t keep = nl == 0 ? r : l;
    nodes_[static_cast<std::size_t>(idx)] = std::move(nodes_[static_cast<std::size_t>(keep)]);
    Node& freed = nodes_[static_cast<std::size_t>(keep)];
    freed.points.clear();
    freed.left = freed.right = -1;
    freed.count = 0;
    freed.dirty = false;
    free_nodes_.push_back(keep);
    nodes_[static_cast<std::size_t>(idx)].dirty = true;
    return nodes_[static_cast<std::size_t>(idx)].count;
  }
  Node& m = nodes_[static_cast<std::size_t>(idx)];
  const Node& a = nodes_[static_cast<std::size_t>(l)];
  const Node& b = nodes_[static_cast<std::size_t>(r)];
  if (m.count != nl + nr) m.dirty = true;
  m.lo = a.lo.cwiseMin(b.lo);
  m.hi = a.hi.cwiseMax(b.hi);
  m.count = nl + nr;
  return m.count;
}

template <class Untouched, class AllDropped, class Drop>
void KdTreeIndex::prune_root(const Untouched& untouched, const AllDropped& all_dropped, const Drop& drop) {
  if (root_ < 0) return;
  if (prune(root_, untouched, all_dropped, drop) == 0) {
    root_ = -1;
    return;
  }
  rebalance(root_);
}

void KdTreeIndex::trim(const Eigen::Vector3f& center, float half_extent) {
  prune_root([&](const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) { return box_inside(lo, hi, center, half_extent); },
             [&](const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) { return box_outside(lo, hi, center, half_extent); },
             [&](const Eigen::Vector3f& p) { return point_outside(p, center, half_extent); });
}

std::size_t KdTreeIndex::erase(const std::vector<Eigen::Vector3f>& points) {
  const std::size_t before = size();
  for (const Eigen::Vector3f& q : points) {
    if (root_ < 0) break;
    prune_root(
        [&](const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) {
          return (q.array() < lo.array()).any() || (q.array() > hi.array()).any();
        },
        [](const Eigen::Vector3f&, const Eigen::Vector3f&) { return false; },
        [&](const Eigen::Vector3f& p) { return p == q; });
  }
  return before - size();
}

void KdTreeIndex::for_each_point(const std::function<void(const Eigen::Vector3f&)>& fn) const {
  // Freed and internal nodes hold no points, so a linear pass over the pool visits each point once.
  for (const Node& n : nodes_) {
    for (const Eigen::Vector3f& p : n.points) fn(p);
  }
}

int KdTreeIndex::depth(std::int32_t idx) const {
  const Node& n = nodes_[static_cast<std::size_t>(idx)];
  if (n.leaf()) return 1;
  return 1 + std::max(depth(n.left), depth(n.right));
}

int KdTreeIndex::depth() const { return root_ < 0 ? 0 : depth(root_); }

}  // namespace fuse

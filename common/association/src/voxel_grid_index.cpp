#include "fuse/association/voxel_grid_index.hpp"

#include <algorithm>
#include <cmath>

namespace fuse {

namespace {
constexpr std::size_t kInitialSlots = 1u << 12;
constexpr double kMaxLoad = 0.5;
/// Rings 0..kPrecomputedShells-1 are precomputed and sorted; farther rings are generated per query.
constexpr int kPrecomputedShells = 5;
/// Voxel boxes are padded by this fraction of the voxel size, so that a point whose key rounding
/// put it in a neighbouring voxel (p · 1/size near an integer) is still never pruned wrongly.
constexpr float kPadFraction = 1e-3f;

std::uint64_t hash_key(const Eigen::Vector3i& k) {
  std::uint64_t h = (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.x())) * 0x9E3779B97F4A7C15ULL) ^
                    (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.y())) << 21) ^
                    (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.z())) << 42);
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ULL;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebULL;
  return h ^ (h >> 31);
}

/// The offsets at Chebyshev distance exactly r (the surface of the (2r+1)³ cube).
std::vector<Eigen::Vector3i> shell(int r) {
  std::vector<Eigen::Vector3i> out;
  for (int x = -r; x <= r; ++x) {
    for (int y = -r; y <= r; ++y) {
      if (std::abs(x) == r || std::abs(y) == r) {
        for (int z = -r; z <= r; ++z) out.emplace_back(x, y, z);
      } else {
        out.emplace_back(x, y, -r);
        if (r > 0) out.emplace_back(x, y, r);
      }
    }
  }
  return out;
}

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
}  // namespace

VoxelGridIndex::VoxelGridIndex(const SpatialIndexConfig& config)
    : config_(config), voxel_size_(static_cast<float>(config.voxel_size)),
      inv_voxel_size_(static_cast<float>(1.0 / config.voxel_size)), pad_(kPadFraction * voxel_size_),
      slots_(kInitialSlots) {
  for (int r = 0; r < kPrecomputedShells; ++r) {
    std::vector<Key> s = shell(r);
    std::stable_sort(s.begin(), s.end(), [](const Key& a, const Key& b) { return a.squaredNorm() < b.squaredNorm(); });
    shells_.push_back(std::move(s));
  }
}

VoxelGridIndex::Key VoxelGridIndex::key_of(const Eigen::Vector3f& p) const {
  return Key(static_cast<int>(std::floor(p.x() * inv_voxel_size_)), static_cast<int>(std::floor(p.y() * inv_voxel_size_)),
             static_cast<int>(std::floor(p.z() * inv_voxel_size_)));
}

std::size_t VoxelGridIndex::slot_of(const Key& key) const {
  const std::size_t mask = slots_.size() - 1;
  std::size_t i = hash_key(key) & mask;
  while (slots_[i].voxel >= 0 && slots_[i].key != key) i = (i + 1) & mask;
  return i;
}

std::int32_t VoxelGridIndex::find(const Key& key) const { return slots_[slot_of(key)].voxel; }

void VoxelGridIndex::rebuild_table(std::size_t capacity) {
  slots_.assign(capacity, Slot{});
  for (std::size_t v = 0; v < voxels_.size(); ++v) {
    if (voxels_[v].points.empty()) continue;
    slots_[slot_of(voxels_[v].key)] = Slot{voxels_[v].key, static_cast<std::int32_t>(v)};
  }
}

void VoxelGridIndex::insert(const std::vector<Eigen::Vector3f>& world_points) {
  for (const Eigen::Vector3f& p : world_points) {
    const Key key = key_of(p);
    const std::size_t s = slot_of(key);
    std::int32_t v = slots_[s].voxel;
    if (v < 0) {
      if (free_voxels_.empty()) {
        v = static_cast<std::int32_t>(voxels_.size());
        voxels_.emplace_back();
      } else {
        v = free_voxels_.back();
        free_voxels_.pop_back();
      }
      voxels_[static_cast<std::size_t>(v)].key = key;
      voxels_[static_cast<std::size_t>(v)].points.reserve(8);
      slots_[s] = Slot{key, v};
      ++num_voxels_;
    }
    Voxel& vox = voxels_[static_cast<std::size_t>(v)];
    if (vox.points.size() < config_.max_points_per_voxel) {
      vox.points.push_back(p);
      ++num_points_;
    }
    // Grow only now: rebuild_table() skips voxel records without points, so a voxel created by
    // this point must hold it first (else the next point of its key would create a duplicate).
    if (static_cast<double>(num_voxels_) > kMaxLoad * static_cast<double>(slots_.size())) {
      rebuild_table(slots_.size() * 2);
    }
  }
}

float VoxelGridIndex::voxel_dist2(const Eigen::Vector3f& q, const Key& key) const {
  const Eigen::Vector3f lo = key.cast<float>() * voxel_size_ - Eigen::Vector3f::Constant(pad_);
  const Eigen::Vector3f hi = lo + Eigen::Vector3f::Constant(voxel_size_ + 2.0f * pad_);
  return (lo - q).cwiseMax(q - hi).cwiseMax(0.0f).squaredNorm();
}

void VoxelGridIndex::scan(const Voxel& voxel, const Eigen::Vector3f& q, int k, float& bound2, Neighbors& out) const {
  for (const Eigen::Vector3f& p : voxel.points) {
    const float d2 = (p - q).squaredNorm();
    if (d2 <= bound2) offer(p, d2, k, bound2, out);
  }
}

void VoxelGridIndex::knn(const Eigen::Vector3f& q, int k, float max_dist, Neighbors& out) const {
  k = std::min(k, Neighbors::kMaxK);
  out.count = 0;
  if (num_points_ == 0 || k <= 0 || !(max_dist >= 0.0f)) return;
  float bound2 = max_dist * max_dist;
  const Key center = key_of(q);
  // Keys the query ball can touch (key_of is monotone; pad_ covers the rounding of distances).
  const Eigen::Vector3f reach = Eigen::Vector3f::Constant(max_dist + pad_);
  const Key lo = key_of(q - reach), hi = key_of(q + reach);
  const int r_max = std::max((center - lo).maxCoeff(), (hi - center).maxCoeff());

  const double side = 2.0 * r_max + 1.0;
  if (side * side * side > 2.0 * static_cast<double>(num_voxels_)) {
    // Fewer occupied voxels than keys in the ball: scan the occupied ones.
    for (const Voxel& v : voxels_) {
      if (v.points.empty() || voxel_dist2(q, v.key) > bound2) continue;
      scan(v, q, k, bound2, out);
    }
    return;
  }

  std::vector<Key> far_shell;
  for (int r = 0; r <= r_max; ++r) {
    const std::vector<Key>* ring = &far_shell;
    if (r < kPrecomputedShells) {
      ring = &shells_[static_cast<std::size_t>(r)];
    } else {
      far_shell = shell(r);
    }
    for (const Key& offset : *ring) {
      const Key key = center + offset;
      if ((key.array() < lo.array()).any() || (key.array() > hi.array()).any()) continue;
      if (voxel_dist2(q, key) > bound2) continue;
      const std::int32_t v = find(key);
      if (v >= 0) scan(voxels_[static_cast<std::size_t>(v)], q, k, bound2, out);
    }
    // Every point not yet seen lies outside the (2r+1)³ block of voxels around center.
    const Eigen::Vector3f block_lo = (center - Key::Constant(r)).cast<float>() * voxel_size_;
    const Eigen::Vector3f block_hi = (center + Key::Constant(r + 1)).cast<float>() * voxel_size_;
    const float gap = std::min((q - block_lo).minCoeff(), (block_hi - q).minCoeff()) - pad_;
    if (gap > 0.0f && gap * gap > bound2) break;
  }
}

void VoxelGridIndex::trim(const Eigen::Vector3f& center, float half_extent) {
  num_points_ = 0;
  for (std::size_t v = 0; v < voxels_.size(); ++v) {
    auto& pts = voxels_[v].points;
    if (pts.empty()) continue;
    pts.erase(std::remove_if(pts.begin(), pts.end(),
                             [&](const Eigen::Vector3f& p) { return ((p - center).cwiseAbs().array() > half_extent).any(); }),
              pts.end());
    if (pts.empty()) {
      std::vector<Eigen::Vector3f>().swap(pts);
      free_voxels_.push_back(static_cast<std::int32_t>(v));
      --num_voxels_;
    }
    num_points_ += pts.size();
  }
  rebuild_table(slots_.size());
}

std::size_t VoxelGridIndex::erase(const std::vector<Eigen::Vector3f>& points) {
  std::size_t removed = 0;
  bool emptied = false;
  for (const Eigen::Vector3f& p : points) {
    const std::int32_t v = find(key_of(p));
    if (v < 0) continue;
    auto& pts = voxels_[static_cast<std::size_t>(v)].points;
    if (pts.empty()) continue;  // emptied earlier in this call: freed below
    const auto end = std::remove(pts.begin(), pts.end(), p);
    removed += static_cast<std::size_t>(pts.end() - end);
    pts.erase(end, pts.end());
    if (pts.empty()) {
      std::vector<Eigen::Vector3f>().swap(pts);
      free_voxels_.push_back(v);
      --num_voxels_;
      emptied = true;
    }
  }
  num_points_ -= removed;
  if (emptied) rebuild_table(slots_.size());
  return removed;
}

void VoxelGridIndex::for_each_point(const std::function<void(const Eigen::Vector3f&)>& fn) const {
  for (const auto& v : voxels_) {
    for (const auto& p : v.points) fn(p);
  }
}

}  // namespace fuse

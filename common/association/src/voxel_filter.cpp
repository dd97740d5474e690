#include "fuse/association/voxel_filter.hpp"

#include <algorithm>
#include <cmath>

namespace fuse {

namespace {
constexpr std::size_t kMinSlots = 1u << 12;
/// Packs three voxel coordinates (21 bits each, offset to be non-negative) into one key.
std::uint64_t pack(std::int64_t x, std::int64_t y, std::int64_t z) {
  constexpr std::int64_t kOffset = 1 << 20;
  constexpr std::uint64_t kMask = (1u << 21) - 1;
  return ((static_cast<std::uint64_t>(x + kOffset) & kMask) << 42) | ((static_cast<std::uint64_t>(y + kOffset) & kMask) << 21) |
         (static_cast<std::uint64_t>(z + kOffset) & kMask);
}
std::uint64_t mix(std::uint64_t k) {  // splitmix64 finaliser: spreads keys over the table
  k ^= k >> 30;
  k *= 0xbf58476d1ce4e5b9ULL;
  k ^= k >> 27;
  k *= 0x94d049bb133111ebULL;
  return k ^ (k >> 31);
}
}  // namespace

void VoxelFilter::filter(const std::vector<Eigen::Vector3f>& points, float voxel_size, std::vector<std::uint32_t>& kept) {
  kept.clear();
  // The table is sized for the number of voxels (not points) and grows when half full: a table
  // that fits in cache matters more than avoiding the occasional rehash.
  if (table_.empty() || ++generation_ == 0) reset_table(std::max<std::size_t>(table_.size(), kMinSlots));
  used_.clear();
  const float inv = 1.0f / voxel_size;
  for (std::uint32_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f v = points[i] * inv;
    const Eigen::Vector3f cell(std::floor(v.x()), std::floor(v.y()), std::floor(v.z()));
    const float d2 = (v - cell - Eigen::Vector3f::Constant(0.5f)).squaredNorm();
    const std::uint64_t key = pack(static_cast<std::int64_t>(cell.x()), static_cast<std::int64_t>(cell.y()),
                                   static_cast<std::int64_t>(cell.z()));
    Slot& s = table_[find_slot(key)];
    if (s.generation != generation_) {
      s = Slot{key, i, d2, generation_};
      used_.push_back(static_cast<std::uint32_t>(&s - table_.data()));
      if (2 * used_.size() > table_.size()) grow();
    } else if (d2 < s.dist2) {
      s.index = i;
      s.dist2 = d2;
    }
  }
  kept.reserve(used_.size());
  for (const std::uint32_t h : used_) kept.push_back(table_[h].index);
  std::sort(kept.begin(), kept.end());
}

void VoxelFilter::reserve(std::size_t points) {
  // The largest table filter() grows to for `points` voxels (it doubles past half load).
  std::size_t slots = kMinSlots;
  while (slots < 2 * points) slots *= 2;
  table_.assign(slots, Slot{0, 0, 0.f, 0});  // written: faulted in; assign() below keeps the capacity
  reset_table(kMinSlots);
  used_.assign(points, 0);
  used_.clear();
}

std::size_t VoxelFilter::find_slot(std::uint64_t key) const {
  const std::uint64_t mask = table_.size() - 1;
  std::uint64_t h = mix(key) & mask;
  while (table_[h].generation == generation_ && table_[h].key != key) h = (h + 1) & mask;
  return h;
}

void VoxelFilter::reset_table(std::size_t capacity) {
  table_.assign(capacity, Slot{0, 0, 0.f, 0});
  generation_ = 1;
}

void VoxelFilter::grow() {
  std::vector<Slot> live;
  live.reserve(used_.size());
  for (const std::uint32_t h : used_) live.push_back(table_[h]);
  reset_table(table_.size() * 2);
  used_.clear();
  for (const Slot& s : live) {
    const std::size_t h = find_slot(s.key);
    table_[h] = Slot{s.key, s.index, s.dist2, generation_};
    used_.push_back(static_cast<std::uint32_t>(h));
  }
}

}  // namespace fuse

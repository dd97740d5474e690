#include "fuse/association/voxel_filter.hpp"

#include <algorithm>
#include <cmath>

namespace fuse {

namespace {
constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
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
  std::size_t capacity = 16;
  while (capacity < 2 * points.size()) capacity <<= 1;
  table_.assign(capacity, Slot{kEmpty, 0, 0.f});
  const std::uint64_t mask = capacity - 1;
  const float inv = 1.0f / voxel_size;
  for (std::uint32_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f v = points[i] * inv;
    const Eigen::Vector3f cell(std::floor(v.x()), std::floor(v.y()), std::floor(v.z()));
    const float d2 = (v - cell - Eigen::Vector3f::Constant(0.5f)).squaredNorm();
    const std::uint64_t key = pack(static_cast<std::int64_t>(cell.x()), static_cast<std::int64_t>(cell.y()),
                                   static_cast<std::int64_t>(cell.z()));
    for (std::uint64_t h = mix(key) & mask;; h = (h + 1) & mask) {
      Slot& s = table_[h];
      if (s.key == kEmpty) {
        s = Slot{key, i, d2};
        break;
      }
      if (s.key == key) {
        if (d2 < s.dist2) s = Slot{key, i, d2};
        break;
      }
    }
  }
  for (const Slot& s : table_) {
    if (s.key != kEmpty) kept.push_back(s.index);
  }
  std::sort(kept.begin(), kept.end());
}

}  // namespace fuse

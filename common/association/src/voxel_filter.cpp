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
/// ⌊x⌋ of a voxel coordinate (finite and within the key's range: filter()'s precondition).
/// Truncation rounds negative values up, so those step down by one.
int floor_int(float x) {
  const int t = static_cast<int>(x);
  return t - static_cast<int>(x < static_cast<float>(t));
}
std::uint64_t mix(std::uint64_t k) {  // splitmix64 finaliser: spreads keys over the table
  k ^= k >> 30;
  k *= 0xbf58476d1ce4e5b9ULL;
  k ^= k >> 27;
  k *= 0x94d049bb133111ebULL;
  return k ^ (k >> 31);
}
}  // namespace

inline std::size_t VoxelFilter::probe(std::size_t h, std::uint64_t key) const {
  const std::uint64_t mask = table_.size() - 1;
  while (table_[h].generation == generation_ && table_[h].key != key) h = (h + 1) & mask;
  return h;
}

std::size_t VoxelFilter::find_slot(std::uint64_t key) const { return probe(mix(key) & (table_.size() - 1), key); }

void VoxelFilter::filter(const std::vector<Eigen::Vector3f>& points, float voxel_size, std::vector<std::uint32_t>& kept) {
  kept.clear();
  // The table is sized for the number of voxels (not points) and grows when half full: a table
  // that fits in cache matters more than avoiding the occasional rehash.
  if (table_.empty() || ++generation_ == 0) reset_table(std::max<std::size_t>(table_.size(), kMinSlots));
  used_.clear();
  const float inv = 1.0f / voxel_size;
  // Pass 1, independent per point: each point's voxel key, its home slot and its squared distance
  // to the voxel centre (in voxel units).
  const std::size_t n = points.size();
  keys_.resize(n);
  homes_.resize(n);
  dist2_.resize(n);
  const std::uint64_t mask = table_.size() - 1;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f v = points[i] * inv;
    const Eigen::Vector3i cell(floor_int(v.x()), floor_int(v.y()), floor_int(v.z()));
    dist2_[i] = (v - cell.cast<float>() - Eigen::Vector3f::Constant(0.5f)).squaredNorm();
    keys_[i] = pack(cell.x(), cell.y(), cell.z());
    homes_[i] = static_cast<std::uint32_t>(mix(keys_[i]) & mask);
  }
  // Pass 2: the table. The slots are scattered over a table larger than the first-level cache;
  // the slot of a point kPrefetchAhead further on is requested now, so its miss overlaps this
  // point's work instead of stalling it.
  constexpr std::size_t kPrefetchAhead = 8;
  for (std::size_t i = 0; i < n; ++i) {
    if (i + kPrefetchAhead < n) __builtin_prefetch(&table_[homes_[i + kPrefetchAhead]]);
    const std::uint64_t key = keys_[i];
    const float d2 = dist2_[i];
    Slot* s = &table_[probe(homes_[i], key)];
    if (s->generation != generation_) {
      *s = Slot{key, static_cast<std::uint32_t>(i), d2, generation_};
      used_.push_back(static_cast<std::uint32_t>(s - table_.data()));
      if (2 * used_.size() > table_.size()) {
        grow();  // moves every slot: the home slots of the points still to come are recomputed
        for (std::size_t j = i + 1; j < n; ++j) homes_[j] = static_cast<std::uint32_t>(mix(keys_[j]) & (table_.size() - 1));
      }
    } else {
      // The closer point wins; on a tie the earlier one stays (a select, not a branch: which
      // point is closer to the centre is a coin toss the branch predictor would lose).
      // Written as a mask: the compiler turned the conditional expressions into that branch.
      const std::uint32_t closer = 0u - static_cast<std::uint32_t>(d2 < s->dist2);  // all ones or 0
      s->index = (static_cast<std::uint32_t>(i) & closer) | (s->index & ~closer);
      s->dist2 = std::min(s->dist2, d2);  // d2 only if smaller
    }
  }
  // The kept indices in input order: marked in a bitmap of the input and read back in order,
  // linear in the input where a sort of the kept was n log n.
  marks_.assign((points.size() + 63) / 64, 0);
  for (const std::uint32_t h : used_) marks_[table_[h].index / 64] |= std::uint64_t{1} << (table_[h].index % 64);
  kept.reserve(used_.size());
  for (std::size_t w = 0; w < marks_.size(); ++w) {
    for (std::uint64_t bits = marks_[w]; bits != 0; bits &= bits - 1) {
      kept.push_back(static_cast<std::uint32_t>(64 * w + static_cast<std::size_t>(__builtin_ctzll(bits))));
    }
  }
}

void VoxelFilter::reserve(std::size_t points) {
  // The largest table filter() grows to for `points` voxels (it doubles past half load).
  std::size_t slots = kMinSlots;
  while (slots < 2 * points) slots *= 2;
  table_.assign(slots, Slot{0, 0, 0.f, 0});  // written: faulted in; assign() below keeps the capacity
  reset_table(kMinSlots);
  // The per-point buffers too, written now and emptied (their capacity stays).
  used_.assign(points, 0);
  used_.clear();
  keys_.assign(points, 0);
  keys_.clear();
  homes_.assign(points, 0);
  homes_.clear();
  dist2_.assign(points, 0.0f);
  dist2_.clear();
  marks_.assign((points + 63) / 64, 0);
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

#include "fuse/association/ivox.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

namespace fuse {

namespace {
constexpr std::size_t kInitialSlots = 1u << 12;
/// The table is kept at most this full (linear probing stays short): it is sized for max_voxels /
/// kMaxLoad slots at construction, and doubles only if it ever holds more.
constexpr double kMaxLoad = 0.5;
/// The largest table made up front (64 MiB).
constexpr std::size_t kMaxPresizedSlots = 1u << 22;
/// Points a new voxel has room for before it moves to a larger chunk.
constexpr std::size_t kFirstCapacity = 8;

/// An index bounded beyond kMaxPresizedSlots (the map server's, which never evicts) is not sized
/// up front: it starts small and grows as it fills.
bool sized_up_front(std::size_t max_voxels) {
  return static_cast<double>(max_voxels) / kMaxLoad <= static_cast<double>(kMaxPresizedSlots);
}

/// Slots for max_voxels at kMaxLoad.
std::size_t presized_slots(std::size_t max_voxels) {
  if (!sized_up_front(max_voxels)) return kInitialSlots;
  std::size_t n = kInitialSlots;
  while (static_cast<double>(n) < static_cast<double>(max_voxels) / kMaxLoad) n *= 2;
  return n;
}

/// Points whose memory is faulted in when the index is made: a first chunk for every voxel of an
/// index sized up front (its records are faulted in with the same budget, by their reserve()).
/// An index too large for that grows its pool as it fills.
std::size_t presized_points(std::size_t max_voxels) {
  return sized_up_front(max_voxels) ? max_voxels * kFirstCapacity : 0;
}

std::vector<Eigen::Vector3i> neighborhood_offsets(const std::string& name) {
  std::vector<Eigen::Vector3i> out;
  for (int x = -1; x <= 1; ++x) {
    for (int y = -1; y <= 1; ++y) {
      for (int z = -1; z <= 1; ++z) {
        const int manhattan = std::abs(x) + std::abs(y) + std::abs(z);
        if (manhattan == 0 || (name == "nearby6" && manhattan == 1) || (name == "nearby18" && manhattan <= 2) ||
            name == "nearby26") {
          out.emplace_back(x, y, z);
        }
      }
    }
  }
  // Nearest voxels first (centre, faces, edges, corners): the k-th distance bound then prunes more.
  std::stable_sort(out.begin(), out.end(),
                   [](const Eigen::Vector3i& a, const Eigen::Vector3i& b) { return a.cwiseAbs().sum() < b.cwiseAbs().sum(); });
  return out;
}

std::uint64_t hash_key(const Eigen::Vector3i& k) {
  // Pack the three coordinates, then the splitmix64 finaliser spreads them over the table.
  std::uint64_t h = (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.x())) * 0x9E3779B97F4A7C15ULL) ^
                    (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.y())) << 21) ^
                    (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.z())) << 42);
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ULL;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebULL;
  return h ^ (h >> 31);
}
}  // namespace

IVox::IVox(const SpatialIndexConfig& config)
    : config_(config), voxel_size_(static_cast<float>(config.voxel_size)),
      inv_voxel_size_(static_cast<float>(1.0 / config.voxel_size)), offsets_(neighborhood_offsets(config.neighborhood)),
      pool_(config.max_points_per_voxel, presized_points(config.max_voxels)) {
  allocate_table(presized_slots(config.max_voxels));
  // The records of a full index, faulted in now (HugePageAllocator); one not sized up front
  // reserves for its first table and grows with it.
  voxels_.reserve(std::min(config.max_voxels, static_cast<std::size_t>(kMaxLoad * static_cast<double>(num_slots_))));
}

IVox::Key IVox::key_of(const Eigen::Vector3f& p) const {
  return Key(static_cast<int>(std::floor(p.x() * inv_voxel_size_)), static_cast<int>(std::floor(p.y() * inv_voxel_size_)),
             static_cast<int>(std::floor(p.z() * inv_voxel_size_)));
}

// Inline (used in this file only): a shared library's exported members are otherwise called,
// not inlined, and these two run 19 times per k-nearest query.
inline std::size_t IVox::home_slot(const Key& key) const { return hash_key(key) & (num_slots_ - 1); }

inline std::size_t IVox::probe(std::size_t i, const Key& key) const {
  const std::size_t mask = num_slots_ - 1;
  while (slots_[i].id != 0 && slots_[i].key != key) i = (i + 1) & mask;
  return i;
}

std::size_t IVox::slot_of(const Key& key) const { return probe(home_slot(key), key); }

std::int32_t IVox::find(const Key& key) const { return slots_[slot_of(key)].id - 1; }

void IVox::allocate_table(std::size_t capacity) {
  // Written whole now (Slot{} is all zeros, as the fresh mapping is): its pages are faulted in
  // here, when the index is made, not by the first scans' lookups.
  HugePageRegion table(capacity * sizeof(Slot));
  slots_ = reinterpret_cast<Slot*>(table.data());
  std::uninitialized_fill_n(slots_, capacity, Slot{});
  table_ = std::move(table);
  num_slots_ = capacity;
}

void IVox::rebuild_table(std::size_t capacity) {
  allocate_table(capacity);
  for (std::size_t v = 0; v < voxels_.size(); ++v) {
    if (voxels_[v].count == 0) continue;
    Slot& slot = slots_[slot_of(voxels_[v].key)];
    slot.key = voxels_[v].key;
    slot.id = static_cast<std::int32_t>(v) + 1;
  }
}

void IVox::erase_slot(std::size_t hole) {
  // Backward-shift deletion (Knuth, TAOCP 6.4, algorithm R): walk the probe run after the hole
  // and move back every entry whose home slot does not lie cyclically in (hole, j]; such an entry
  // would otherwise be cut off from its home by the empty slot. No tombstones are left behind.
  const std::size_t mask = num_slots_ - 1;
  for (std::size_t j = (hole + 1) & mask; slots_[j].id != 0; j = (j + 1) & mask) {
    const std::size_t home = home_slot(slots_[j].key);
    const bool reachable = hole <= j ? (hole < home && home <= j) : (hole < home || home <= j);
    if (reachable) continue;
    slots_[hole] = slots_[j];
    hole = j;
  }
  slots_[hole] = Slot{};
}

void IVox::link_newest(std::int32_t v) {
  Voxel& vox = voxels_[v];
  vox.older = newest_;
  vox.newer = -1;
  if (newest_ >= 0) voxels_[newest_].newer = v;
  newest_ = v;
  if (oldest_ < 0) oldest_ = v;
}

void IVox::unlink(std::int32_t v) {
  Voxel& vox = voxels_[v];
  (vox.older >= 0 ? voxels_[vox.older].newer : oldest_) = vox.newer;
  (vox.newer >= 0 ? voxels_[vox.newer].older : newest_) = vox.older;
  vox.older = vox.newer = -1;
}

void IVox::free_voxel(std::int32_t v) {
  Voxel& vox = voxels_[v];
  unlink(v);
  erase_slot(slot_of(vox.key));
  num_points_ -= vox.count;
  vox.count = 0;  // the record keeps its chunk for the voxel made next in its place
  free_voxels_.push_back(v);
  --num_voxels_;
}

void IVox::evict_least_recent() { free_voxel(oldest_); }

std::size_t IVox::erase(const std::vector<Eigen::Vector3f>& points) {
  std::size_t removed = 0;
  for (const Eigen::Vector3f& p : points) {
    const std::int32_t v = find(key_of(p));
    if (v < 0) continue;
    Voxel& vox = voxels_[v];
    Eigen::Vector3f* const begin = vox.points.data;
    const auto n = static_cast<std::size_t>(begin + vox.count - std::remove(begin, begin + vox.count, p));
    vox.count -= static_cast<std::uint32_t>(n);
    removed += n;
    num_points_ -= n;
    if (vox.count == 0) free_voxel(v);  // free_voxel subtracts the (now zero) points
  }
  return removed;
}

void IVox::insert(const std::vector<Eigen::Vector3f>& world_points) {
  ++clock_;
  pool_.prepare();
  for (const Eigen::Vector3f& p : world_points) {
    const Key key = key_of(p);
    std::size_t s = slot_of(key);
    std::int32_t v = slots_[s].id - 1;
    if (v < 0) {
      if (num_voxels_ >= config_.max_voxels) {
        evict_least_recent();
        s = slot_of(key);  // the deletion may have shifted the probe run
      }
      if (free_voxels_.empty()) {
        v = static_cast<std::int32_t>(voxels_.size());
        voxels_.emplace_back();
      } else {
        v = free_voxels_.back();
        free_voxels_.pop_back();
      }
      voxels_[v].key = key;
      voxels_[v].last_touch = clock_;
      if (voxels_[v].points.data == nullptr) voxels_[v].points = pool_.allocate(kFirstCapacity);
      slots_[s].key = key;
      slots_[s].id = v + 1;
      link_newest(v);
      ++num_voxels_;
    } else if (voxels_[v].last_touch != clock_) {
      voxels_[v].last_touch = clock_;
      unlink(v);
      link_newest(v);
    }
    Voxel& vox = voxels_[v];
    if (vox.count < config_.max_points_per_voxel) {
      if (vox.count == vox.points.capacity) {  // full chunk: move to one twice its size
        const PointPool::Chunk larger = pool_.allocate(2 * std::size_t{vox.count});
        std::memcpy(static_cast<void*>(larger.data), vox.points.data, vox.count * sizeof(Eigen::Vector3f));
        pool_.release(vox.points);
        vox.points = larger;
      }
      vox.points.data[vox.count++] = p;
      ++num_points_;
    }
    // Grow only now: rebuild_table() skips voxel records without points, so a voxel created by
    // this point must hold it first (else the next point of its key would create a duplicate).
    // Only an index too large to be sized up front (the map server's) gets here.
    if (static_cast<double>(num_voxels_) > kMaxLoad * static_cast<double>(num_slots_)) {
      rebuild_table(num_slots_ * 2);
    }
  }
}

void IVox::knn(const Eigen::Vector3f& q, int k, float max_dist, Neighbors& out) const {
  k = std::min(k, Neighbors::kMaxK);
  out.count = 0;
  float bound2 = max_dist * max_dist;  // squared radius that can still improve the result
  const Key center = key_of(q);
  // The squared gap from q to a neighbour voxel's box is a sum over the axes of the squared gap
  // to the centre voxel's low face (offset −1), nothing (0) or its high face (+1), as q lies in
  // the centre voxel: gap2[axis][offset + 1].
  const Eigen::Vector3f below = q - center.cast<float>() * voxel_size_;
  const Eigen::Vector3f above = Eigen::Vector3f::Constant(voxel_size_) - below;
  float gap2[3][3];
  for (int a = 0; a < 3; ++a) {
    gap2[a][0] = below[a] * below[a];
    gap2[a][1] = 0.0f;
    gap2[a][2] = above[a] * above[a];
  }
  // The neighbourhood's voxels lie scattered over a table far larger than the caches, so each
  // lookup is a cache miss. Asking for all of them first lets the misses overlap (memory-level
  // parallelism) instead of following one another: the slots, then the voxel records, then
  // their points.
  const std::size_t n = offsets_.size();
  std::array<std::size_t, kMaxOffsets> slot;
  for (std::size_t i = 0; i < n; ++i) {
    slot[i] = home_slot(center + offsets_[i]);
    __builtin_prefetch(&slots_[slot[i]]);
  }
  // The voxels that exist, in neighbourhood order, gathered without a branch per neighbour.
  std::array<std::int32_t, kMaxOffsets> id;
  std::array<std::uint8_t, kMaxOffsets> which;
  std::size_t found = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::int32_t v = slots_[probe(slot[i], center + offsets_[i])].id - 1;
    __builtin_prefetch(voxels_.data() + std::max(v, 0));  // a voxel that exists, else the first record (harmless)
    id[found] = v;
    which[found] = static_cast<std::uint8_t>(i);
    found += v >= 0 ? 1 : 0;
  }
  for (std::size_t j = 0; j < found; ++j) __builtin_prefetch(voxels_[id[j]].points.data);
  for (std::size_t j = 0; j < found; ++j) {
    // Skip a voxel whose box is farther from q than the current k-th neighbour (or max_dist).
    const Key& o = offsets_[which[j]];
    if (gap2[0][o.x() + 1] + gap2[1][o.y() + 1] + gap2[2][o.z() + 1] > bound2) continue;
    // Keep the k best in a small sorted array (insertion sort: k ≤ 16).
    const Voxel& vox = voxels_[id[j]];
    for (const Eigen::Vector3f* it = vox.points.data; it != vox.points.data + vox.count; ++it) {
      const Eigen::Vector3f& p = *it;
      const float d2 = (p - q).squaredNorm();
      if (d2 > bound2) continue;
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
  }
}

void IVox::trim(const Eigen::Vector3f& center, float half_extent) {
  num_points_ = 0;
  for (std::size_t v = 0; v < voxels_.size(); ++v) {
    Voxel& vox = voxels_[v];
    if (vox.count == 0) continue;
    Eigen::Vector3f* const begin = vox.points.data;
    vox.count = static_cast<std::uint32_t>(
        std::remove_if(begin, begin + vox.count,
                       [&](const Eigen::Vector3f& p) { return ((p - center).cwiseAbs().array() > half_extent).any(); }) -
        begin);
    if (vox.count == 0) {
      pool_.release(vox.points);
      vox.points = PointPool::Chunk{};
      unlink(static_cast<std::int32_t>(v));
      free_voxels_.push_back(static_cast<std::int32_t>(v));
      --num_voxels_;
    }
    num_points_ += vox.count;
  }
  rebuild_table(num_slots_);
}

void IVox::for_each_point(const std::function<void(const Eigen::Vector3f&)>& fn) const {
  for (const Voxel& v : voxels_) {
    for (std::uint32_t i = 0; i < v.count; ++i) fn(v.points.data[i]);
  }
}

}  // namespace fuse

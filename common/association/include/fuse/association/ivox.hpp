// Hash-voxel index in the style of iVox (Bai et al., Faster-LIO, 2022): points bucketed in cubic
// voxels keyed by integer coordinates; k-nearest search scans the query's voxel and a fixed
// neighbourhood of voxels (nearest first, skipping voxels farther than the current k-th
// neighbour). Voxels are kept in a least-recently-touched list (touch = an insert into them);
// beyond `max_voxels` the least recently touched voxel is evicted for each new one, which bounds
// memory over long runs (LRU).
//
// The hash table is open-addressing with linear probing over a power-of-two array of slots that
// hold the key and the voxel's index: a lookup is one mixed hash, no division, no pointer chase.
//
// Memory: the table, the voxel records and the voxels' points (point_pool.hpp) are kept in
// transparent huge pages (huge_page_memory.hpp), so the search's scattered reads miss the TLB
// rarely and the map's first touches take one fault per 2 MiB.
//
// No insert costs more than its points: the table is sized for `max_voxels` and written once when
// the index is made (a page touched for the first time costs a fault; a lookup into a table whose
// pages are still untouched would take thousands of them in the first scans), so it never grows
// while an estimator inserts, and an eviction unlinks one voxel and closes its slot's probe run in
// place (backward-shift deletion) instead of rebuilding the table.
#pragma once

#include <cstdint>
#include <vector>

#include "fuse/association/huge_page_memory.hpp"
#include "fuse/association/point_pool.hpp"
#include "fuse/association/spatial_index.hpp"

namespace fuse {

class IVox final : public SpatialIndex {
 public:
  explicit IVox(const SpatialIndexConfig& config);
  IVox(const IVox&) = delete;  // voxel records point into the pool
  IVox& operator=(const IVox&) = delete;

  void insert(const std::vector<Eigen::Vector3f>& world_points) override;
  void knn(const Eigen::Vector3f& q, int k, float max_dist, Neighbors& out) const override;
  void trim(const Eigen::Vector3f& center, float half_extent) override;
  std::size_t erase(const std::vector<Eigen::Vector3f>& points) override;
  std::size_t size() const override { return num_points_; }
  void for_each_point(const std::function<void(const Eigen::Vector3f&)>& fn) const override;
  std::string name() const override { return "ivox"; }
  std::size_t num_voxels() const { return num_voxels_; }
  /// Slots of the hash table (for tests: it is sized at construction and grows only past
  /// the size it was made for).
  std::size_t num_slots() const { return num_slots_; }

 private:
  using Key = Eigen::Vector3i;
  static constexpr std::size_t kMaxOffsets = 27;  ///< nearby26 and the centre
  struct Slot {
    Key key = Key::Zero();
    std::int32_t id = 0;  ///< index into voxels_ plus one; 0 = empty
  };
  struct Voxel {
    Key key = Key::Zero();
    std::uint32_t count = 0;  ///< points held; 0 = free voxel record
    std::uint64_t last_touch = 0;
    std::int32_t older = -1, newer = -1;  ///< neighbours in the LRU list
    PointPool::Chunk points;              ///< kept by a free record for the voxel made next in its place
  };

  Key key_of(const Eigen::Vector3f& p) const;
  std::size_t home_slot(const Key& key) const;  ///< where key's probe run starts
  std::size_t probe(std::size_t home, const Key& key) const;  ///< linear probing from home
  std::size_t slot_of(const Key& key) const;  ///< the slot holding key, or the empty slot where it goes
  std::int32_t find(const Key& key) const;    ///< voxel index, -1 if absent
  void allocate_table(std::size_t capacity);  ///< empty slots
  void rebuild_table(std::size_t capacity);
  void erase_slot(std::size_t slot);
  void link_newest(std::int32_t v);
  void unlink(std::int32_t v);
  void evict_least_recent();
  void free_voxel(std::int32_t v);  ///< unlinks an emptied or evicted voxel and frees its slot

  SpatialIndexConfig config_;
  float voxel_size_, inv_voxel_size_;
  std::vector<Key> offsets_;
  HugePageRegion table_;
  Slot* slots_ = nullptr;  ///< in table_
  std::size_t num_slots_ = 0;
  PointPool pool_;
  std::vector<Voxel, HugePageAllocator<Voxel>> voxels_;
  std::vector<std::int32_t> free_voxels_;
  std::int32_t oldest_ = -1, newest_ = -1;  ///< ends of the LRU list
  std::size_t num_voxels_ = 0, num_points_ = 0;
  std::uint64_t clock_ = 0;
};

}  // namespace fuse

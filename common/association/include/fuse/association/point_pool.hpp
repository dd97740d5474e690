// Storage for the points of iVox's voxels (ivox.hpp): chunks of 8, 16, 32, ... points, up to the
// voxel's limit, carved from blocks of transparent huge pages (huge_page_memory.hpp), with one
// free list per chunk size. A voxel that fills its chunk moves to one twice its size, as a
// std::vector would, but the chunks of all voxels share a few huge pages instead of scattering
// over the heap's 4 KiB pages, so the k-nearest search's reads miss the TLB far less.
//
// A reserve of blocks is faulted in when the pool is made (huge_page_memory.hpp says why). Past
// it, the next block is mapped ahead and prepare() faults a slice of it in before each batch of
// inserts, so no insert pays for a whole block of first touches at once. Blocks are taken one at
// a time as the map grows and never returned: a freed chunk goes on its size's free list for the
// next voxel of that size.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fuse/association/huge_page_memory.hpp"

namespace fuse {

class PointPool {
 public:
  struct Chunk {
    Eigen::Vector3f* data = nullptr;
    std::uint32_t capacity = 0;  ///< points it can hold
  };

  /// Chunks hold at most max_points (≥ 1) points; blocks for reserve_points points are faulted
  /// in now.
  explicit PointPool(std::size_t max_points, std::size_t reserve_points = 0);
  PointPool(const PointPool&) = delete;
  PointPool& operator=(const PointPool&) = delete;

  /// The smallest chunk with room for min(points, max_points) points. Throws std::bad_alloc.
  Chunk allocate(std::size_t points);
  /// Gives a chunk from allocate() back for reuse.
  void release(const Chunk& chunk);
  /// Faults in the next slice of the block mapped ahead (call once per batch of inserts).
  void prepare();

  /// Blocks carved into chunks so far, and blocks faulted in and waiting.
  std::size_t num_blocks() const { return blocks_.size(); }
  std::size_t num_ready_blocks() const { return ready_.size(); }
  /// Chunks of this capacity waiting on the free list (for tests).
  std::size_t num_free(std::uint32_t capacity) const;

 private:
  struct SizeClass {
    std::uint32_t capacity = 0;
    std::vector<Eigen::Vector3f*> free;
    char* next = nullptr;  ///< the unused rest of this size's current block
    char* end = nullptr;
  };
  SizeClass& class_for(std::size_t points);
  char* take_block(std::size_t bytes);  ///< a new block for one size, returns its start

  std::vector<SizeClass> classes_;
  std::vector<HugePageRegion> blocks_;
  std::vector<HugePageRegion> ready_;  ///< the reserve: faulted in, not yet carved
  HugePageRegion spare_;  ///< the next block, faulted in by prepare() a slice at a time
  std::size_t spare_touched_ = 0;
};

}  // namespace fuse

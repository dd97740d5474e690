// Voxel-grid downsampling: keeps, per cubic voxel, the point closest to the voxel centre.
// An open-addressing hash table (generation-stamped, reused between calls, sized to the number of
// voxels) avoids per-point heap allocation and stays in cache.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace fuse {

class VoxelFilter {
 public:
  /// Writes into `kept` the indices (into points) of the points retained, in input order. The
  /// points must be finite and within 2²⁰ voxels of the origin (the key's range): callers pass
  /// range-checked points (PreprocessConfig::range_gate, whose bounds its load() keeps inside).
  void filter(const std::vector<Eigen::Vector3f>& points, float voxel_size, std::vector<std::uint32_t>& kept);
  /// Makes room for clouds of up to `points` points and faults it in now, so that no filter()
  /// call allocates for them. The table in use stays as small as the clouds need.
  void reserve(std::size_t points);

 private:
  struct Slot {
    std::uint64_t key;
    std::uint32_t index;
    float dist2;
    std::uint32_t generation;  ///< slot is in use only when equal to generation_ (no clearing)
  };
  std::size_t find_slot(std::uint64_t key) const;
  std::size_t probe(std::size_t home, std::uint64_t key) const;  ///< linear probing from home
  void reset_table(std::size_t capacity);
  void grow();

  std::vector<Slot> table_;  ///< reused between calls
  std::vector<std::uint32_t> used_;  ///< slots filled by the current call
  std::vector<std::uint64_t> marks_;  ///< one bit per input point: kept
  std::vector<std::uint64_t> keys_;   ///< per input point: its voxel
  std::vector<std::uint32_t> homes_;  ///< per input point: its voxel's home slot
  std::vector<float> dist2_;          ///< per input point: squared distance to its voxel's centre
  std::uint32_t generation_ = 0;
};

}  // namespace fuse

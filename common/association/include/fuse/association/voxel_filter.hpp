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
  /// Writes into `kept` the indices (into points) of the points retained, in input order.
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
  void reset_table(std::size_t capacity);
  void grow();

  std::vector<Slot> table_;  ///< reused between calls
  std::vector<std::uint32_t> used_;  ///< slots filled by the current call
  std::uint32_t generation_ = 0;
};

}  // namespace fuse

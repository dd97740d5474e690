// Voxel-grid downsampling: keeps, per cubic voxel, the point closest to the voxel centre.
// An open-addressing hash table sized to the input avoids per-point heap allocation.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace fuse {

class VoxelFilter {
 public:
  /// Writes into `kept` the indices (into points) of the points retained, in input order.
  void filter(const std::vector<Eigen::Vector3f>& points, float voxel_size, std::vector<std::uint32_t>& kept);

 private:
  struct Slot {
    std::uint64_t key;
    std::uint32_t index;
    float dist2;
  };
  std::vector<Slot> table_;  ///< reused between calls
};

}  // namespace fuse

// Plain voxel-grid index (type "voxel_grid"): a hash map from cubic voxel (integer key) to the
// points in it (at most max_points_per_voxel; further points into a full voxel are refused).
// Unlike iVox there is no LRU eviction (only trim() removes points) and no fixed neighbourhood:
// k-nearest search is exact within max_dist. It scans shells of voxels around the query's voxel
// (ring r = the voxels at Chebyshev distance r, each ring nearest voxels first), skipping voxels
// whose box is farther than the current k-th neighbour, and stops once the k-th neighbour is
// closer than anything outside the rings scanned so far, or the rings cover the query ball. When
// the ball spans more voxel keys than there are occupied voxels, it scans the occupied voxels
// instead (large radii on sparse maps).
//
// The hash table is open addressing with linear probing over a power-of-two array of slots
// holding the key and the voxel's index (as in ivox.hpp).
#pragma once

#include <cstdint>
#include <vector>

#include "fuse/association/spatial_index.hpp"

namespace fuse {

class VoxelGridIndex final : public SpatialIndex {
 public:
  explicit VoxelGridIndex(const SpatialIndexConfig& config);

  void insert(const std::vector<Eigen::Vector3f>& world_points) override;
  void knn(const Eigen::Vector3f& q, int k, float max_dist, Neighbors& out) const override;
  void trim(const Eigen::Vector3f& center, float half_extent) override;
  /// A voxel emptied by erase is freed and the table rebuilt once per call (this index is the
  /// exact reference, not the fast one: ivox erases in place).
  std::size_t erase(const std::vector<Eigen::Vector3f>& points) override;
  std::size_t size() const override { return num_points_; }
  void for_each_point(const std::function<void(const Eigen::Vector3f&)>& fn) const override;
  std::string name() const override { return "voxel_grid"; }
  std::size_t num_voxels() const { return num_voxels_; }

 private:
  using Key = Eigen::Vector3i;
  struct Slot {
    Key key;
    std::int32_t voxel = -1;  ///< index into voxels_, -1 = empty
  };
  struct Voxel {
    Key key;
    std::vector<Eigen::Vector3f> points;  ///< empty = free voxel record
  };

  Key key_of(const Eigen::Vector3f& p) const;
  std::size_t slot_of(const Key& key) const;
  std::int32_t find(const Key& key) const;
  void rebuild_table(std::size_t capacity);
  /// Squared distance from q to the (slightly padded) box of voxel key.
  float voxel_dist2(const Eigen::Vector3f& q, const Key& key) const;
  void scan(const Voxel& voxel, const Eigen::Vector3f& q, int k, float& bound2, Neighbors& out) const;

  SpatialIndexConfig config_;
  float voxel_size_, inv_voxel_size_, pad_;
  std::vector<std::vector<Key>> shells_;  ///< precomputed rings 0..n-1, nearest offsets first
  std::vector<Slot> slots_;
  std::vector<Voxel> voxels_;
  std::vector<std::int32_t> free_voxels_;
  std::size_t num_voxels_ = 0, num_points_ = 0;
};

}  // namespace fuse

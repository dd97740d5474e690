// Hash-voxel index in the style of iVox (Bai et al., Faster-LIO, 2022): points bucketed in cubic
// voxels keyed by integer coordinates in a hash map; k-nearest search scans the query's voxel and a
// fixed neighbourhood of voxels; voxels are kept in least-recently-used order and the oldest are
// evicted beyond a capacity, which bounds memory over long runs.
#pragma once

#include <list>
#include <unordered_map>

#include "fuse/association/spatial_index.hpp"

namespace fuse {

class IVox final : public SpatialIndex {
 public:
  explicit IVox(const SpatialIndexConfig& config);

  void insert(const std::vector<Eigen::Vector3f>& world_points) override;
  void knn(const Eigen::Vector3f& q, int k, float max_dist, Neighbors& out) const override;
  void trim(const Eigen::Vector3f& center, float half_extent) override;
  std::size_t size() const override { return num_points_; }
  void for_each_point(const std::function<void(const Eigen::Vector3f&)>& fn) const override;
  std::string name() const override { return "ivox"; }
  std::size_t num_voxels() const { return voxels_.size(); }

 private:
  using Key = Eigen::Vector3i;
  struct KeyHash {
    std::size_t operator()(const Key& k) const {
      // Spatial hash of Teschner et al. (2003): XOR of coordinates times large primes.
      return static_cast<std::size_t>((k.x() * 73856093) ^ (k.y() * 19349663) ^ (k.z() * 83492791));
    }
  };
  struct KeyEq {
    bool operator()(const Key& a, const Key& b) const { return a == b; }
  };
  struct Voxel {
    Key key;
    std::vector<Eigen::Vector3f> points;
  };
  using LruList = std::list<Voxel>;

  Key key_of(const Eigen::Vector3f& p) const;

  SpatialIndexConfig config_;
  float inv_voxel_size_;
  std::vector<Key> offsets_;
  LruList voxels_;  ///< front = most recently inserted into
  std::unordered_map<Key, LruList::iterator, KeyHash, KeyEq> table_;
  std::size_t num_points_ = 0;
};

}  // namespace fuse

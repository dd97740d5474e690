// Spatial role (DESIGN §1): the map's nearest-neighbour index. Implementations are chosen by
// config (make_spatial_index) and tested against a brute-force oracle: ivox (ivox.hpp, hash
// voxels with a fixed neighbourhood and LRU eviction), kdtree (kdtree_index.hpp, incremental
// kd-tree, exact) and voxel_grid (voxel_grid_index.hpp, hash voxels searched in rings, exact).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "fuse/core/config.hpp"

namespace fuse {

/// Result of a k-nearest search, sorted by increasing distance.
struct Neighbors {
  static constexpr int kMaxK = 16;
  int count = 0;
  Eigen::Vector3f points[kMaxK];
  float dist2[kMaxK];
};

class SpatialIndex {
 public:
  virtual ~SpatialIndex() = default;
  virtual void insert(const std::vector<Eigen::Vector3f>& world_points) = 0;
  /// Up to k (≤ Neighbors::kMaxK) nearest points within max_dist of q.
  virtual void knn(const Eigen::Vector3f& q, int k, float max_dist, Neighbors& out) const = 0;
  /// Removes every point outside the axis-aligned box of half size half_extent around center.
  virtual void trim(const Eigen::Vector3f& center, float half_extent) = 0;
  /// Removes every stored point equal to one of `points` (a map policy taking back what it
  /// inserted); points not stored are ignored. Returns how many were removed.
  virtual std::size_t erase(const std::vector<Eigen::Vector3f>& points) = 0;
  virtual std::size_t size() const = 0;
  virtual void for_each_point(const std::function<void(const Eigen::Vector3f&)>& fn) const = 0;
  virtual std::string name() const = 0;
};

struct SpatialIndexConfig {
  std::string type = "ivox";           ///< ivox | kdtree | voxel_grid
  double voxel_size = 0.5;             ///< cell edge of ivox and voxel_grid, m (kdtree: unused)
  std::string neighborhood = "nearby18";  ///< ivox only: center | nearby6 | nearby18 | nearby26
  std::size_t max_voxels = 1000000;    ///< ivox only: LRU capacity (least recently touched voxels evicted)
  std::size_t max_points_per_voxel = 64;  ///< ivox, voxel_grid: refuse further inserts into a full voxel
  void load(ConfigNode& node);
};

std::unique_ptr<SpatialIndex> make_spatial_index(const SpatialIndexConfig& config);

}  // namespace fuse

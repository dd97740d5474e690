// iVox specifics (ivox.hpp): the LRU capacity bounds the voxel count and evicts the voxels least
// recently inserted into (touch time = the insert() call); a full voxel refuses further points.
#include "fuse/association/ivox.hpp"

#include <gtest/gtest.h>

#include <random>

#include "oracle.hpp"

namespace fuse {
namespace {

constexpr double kVoxel = 1.0;

SpatialIndexConfig small_config(std::size_t max_voxels) {
  SpatialIndexConfig cfg;
  cfg.voxel_size = kVoxel;
  cfg.neighborhood = "center";
  cfg.max_voxels = max_voxels;
  return cfg;
}

/// A point in the middle of voxel (i, 0, 0).
Eigen::Vector3f in_voxel(int i) { return Eigen::Vector3f(i + 0.5f, 0.5f, 0.5f); }

bool has_points_near(const IVox& ivox, const Eigen::Vector3f& q) {
  Neighbors nb;
  ivox.knn(q, 1, 0.4f, nb);
  return nb.count > 0;
}

TEST(IVox, LruEvictsTheLeastRecentlyTouchedVoxel) {
  IVox ivox(small_config(3));  // capacity 3: one voxel is evicted at a time
  for (int i : {0, 1, 2}) ivox.insert({in_voxel(i)});  // touched in the order 0, 1, 2
  ivox.insert({in_voxel(0)});                         // touch 0 again: 1 is now the least recent
  ivox.insert({in_voxel(3)});                         // a 4th voxel evicts voxel 1
  EXPECT_EQ(ivox.num_voxels(), 3u);
  EXPECT_FALSE(has_points_near(ivox, in_voxel(1)));
  for (int i : {0, 2, 3}) EXPECT_TRUE(has_points_near(ivox, in_voxel(i))) << "voxel " << i;
  EXPECT_EQ(ivox.size(), 4u);  // voxel 0 holds two points, 2 and 3 one each
}

TEST(IVox, CapacityBoundsVoxelCountOverALongRun) {
  constexpr std::size_t kCapacity = 1000;
  IVox ivox(small_config(kCapacity));
  std::mt19937 rng(80);
  for (int batch = 0; batch < 20; ++batch) {
    ivox.insert(test::random_cloud(rng, 2000, 20.0f));  // ~64000 voxels touched in total
    EXPECT_LE(ivox.num_voxels(), kCapacity);
    EXPECT_GT(ivox.num_voxels(), kCapacity / 2);  // evicts a fraction at a time, not everything
  }
  std::size_t visited = 0;
  ivox.for_each_point([&](const Eigen::Vector3f&) { ++visited; });
  EXPECT_EQ(ivox.size(), visited);
  // The newest batch survives eviction (it is the most recently touched).
  const auto last = test::random_cloud(rng, 200, 20.0f);
  ivox.insert(last);
  for (const Eigen::Vector3f& p : last) ASSERT_TRUE(has_points_near(ivox, p)) << p.transpose();
}

TEST(IVox, FullVoxelRefusesPoints) {
  SpatialIndexConfig cfg = small_config(1000);
  cfg.max_points_per_voxel = 4;
  IVox ivox(cfg);
  ivox.insert(std::vector<Eigen::Vector3f>(10, in_voxel(0)));
  EXPECT_EQ(ivox.size(), 4u);
}

}  // namespace
}  // namespace fuse

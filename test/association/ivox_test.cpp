// iVox specifics (ivox.hpp): the LRU capacity bounds the voxel count and evicts the voxels least
// recently inserted into (touch time = the insert() call); a full voxel refuses further points;
// evictions delete from the hash table in place and leave every other voxel findable; the table
// is sized once for the capacity.
#include "fuse/association/ivox.hpp"

#include <gtest/gtest.h>

#include <random>
#include <set>
#include <tuple>

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
    EXPECT_GT(ivox.num_voxels(), kCapacity / 2);  // evicts what it must, not everything
  }
  std::size_t visited = 0;
  ivox.for_each_point([&](const Eigen::Vector3f&) { ++visited; });
  EXPECT_EQ(ivox.size(), visited);
  // The newest batch survives eviction (it is the most recently touched).
  const auto last = test::random_cloud(rng, 200, 20.0f);
  ivox.insert(last);
  for (const Eigen::Vector3f& p : last) ASSERT_TRUE(has_points_near(ivox, p)) << p.transpose();
}

TEST(IVox, EvictionsLeaveEveryOtherVoxelFindable) {
  // Many evictions from a table whose probe runs are long (a dense cube of small voxels): after
  // each batch every held point is found at distance 0, the voxel count is the number of distinct
  // voxels held, and k-nearest answers equal the brute-force ones over the held points.
  SpatialIndexConfig cfg = small_config(1500);
  cfg.voxel_size = 0.25;
  cfg.neighborhood = "nearby26";
  IVox ivox(cfg);
  std::mt19937 rng(19);
  for (int batch = 0; batch < 30; ++batch) {
    ivox.insert(test::random_cloud(rng, 400, 3.0f));
    std::vector<Eigen::Vector3f> held;
    std::set<std::tuple<int, int, int>> keys;
    ivox.for_each_point([&](const Eigen::Vector3f& p) {
      held.push_back(p);
      const Eigen::Vector3i k = (p / 0.25f).array().floor().cast<int>();
      keys.emplace(k.x(), k.y(), k.z());
    });
    ASSERT_EQ(held.size(), ivox.size());
    ASSERT_EQ(keys.size(), ivox.num_voxels()) << "batch " << batch;
    Neighbors nb;
    for (const Eigen::Vector3f& p : held) {
      ivox.knn(p, 1, 0.01f, nb);
      ASSERT_EQ(nb.count, 1) << "batch " << batch << ": held point " << p.transpose() << " not found";
      ASSERT_EQ(nb.dist2[0], 0.0f);
    }
    for (const Eigen::Vector3f& q : test::random_cloud(rng, 50, 3.0f)) {
      ivox.knn(q, 5, 0.25f, nb);  // within one voxel: the 26-neighbourhood covers the radius
      const std::vector<float> expected = test::brute_force_knn(held, q, 5, 0.25f);
      ASSERT_EQ(static_cast<std::size_t>(nb.count), expected.size());
      for (int i = 0; i < nb.count; ++i) ASSERT_FLOAT_EQ(nb.dist2[i], expected[static_cast<std::size_t>(i)]);
    }
  }
}

TEST(IVox, TheTableIsSizedOnceForItsCapacity) {
  // No insert pays for a rehash: the slots are there from the start, for max_voxels at half load.
  IVox ivox(small_config(5000));
  const std::size_t slots = ivox.num_slots();
  EXPECT_GE(slots, 10000u);
  std::mt19937 rng(7);
  for (int batch = 0; batch < 40; ++batch) ivox.insert(test::random_cloud(rng, 1000, 30.0f));
  EXPECT_EQ(ivox.num_voxels(), 5000u);  // full, evicting one voxel per new one
  EXPECT_EQ(ivox.num_slots(), slots);
}

TEST(IVox, PointsSurviveMovesToLargerChunks) {
  // Voxels filled a few points per insert move through chunks of 8, 16, 32 and 64 points: every
  // point inserted stays stored and found; erasing and trimming from grown voxels works, and the
  // voxels made after a trim get chunks again.
  SpatialIndexConfig cfg = small_config(1000);
  cfg.neighborhood = "nearby26";
  IVox ivox(cfg);
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Eigen::Vector3f> held;
  for (int batch = 0; batch < 20; ++batch) {
    std::vector<Eigen::Vector3f> points;
    for (int voxel = 0; voxel < 4; ++voxel) {
      for (int i = 0; i < 3; ++i) points.emplace_back(static_cast<float>(voxel) + u(rng), u(rng), u(rng));
    }
    ivox.insert(points);
    held.insert(held.end(), points.begin(), points.end());
  }
  ASSERT_EQ(ivox.size(), held.size());  // 60 points per voxel: below the limit of 64
  Neighbors nb;
  for (const Eigen::Vector3f& q : held) {
    ivox.knn(q, 16, 1.0f, nb);
    const std::vector<float> expected = test::brute_force_knn(held, q, 16, 1.0f);
    ASSERT_EQ(static_cast<std::size_t>(nb.count), expected.size());
    for (int i = 0; i < nb.count; ++i) ASSERT_FLOAT_EQ(nb.dist2[i], expected[static_cast<std::size_t>(i)]);
  }
  // Erase every other point of voxel 0.
  std::vector<Eigen::Vector3f> gone;
  std::vector<Eigen::Vector3f> kept;
  for (const Eigen::Vector3f& p : held) ((p.x() < 1.0f && gone.size() <= kept.size()) ? gone : kept).push_back(p);
  EXPECT_EQ(ivox.erase(gone), gone.size());
  EXPECT_EQ(ivox.size(), kept.size());
  for (const Eigen::Vector3f& p : gone) {
    ivox.knn(p, 1, 1.0f, nb);
    EXPECT_TRUE(nb.count == 0 || nb.dist2[0] > 0.0f) << "erased point " << p.transpose() << " still found";
  }
  // Trim to voxels 0 and 1: the other two give their chunks back; voxels made next take chunks again.
  ivox.trim(Eigen::Vector3f(1.0f, 0.5f, 0.5f), 1.0f);
  EXPECT_EQ(ivox.num_voxels(), 2u);
  for (int voxel = 10; voxel < 12; ++voxel) {
    ivox.insert(std::vector<Eigen::Vector3f>(40, in_voxel(voxel)));
    EXPECT_TRUE(has_points_near(ivox, in_voxel(voxel)));
  }
  EXPECT_EQ(ivox.num_voxels(), 4u);
  std::size_t visited = 0;
  ivox.for_each_point([&](const Eigen::Vector3f&) { ++visited; });
  EXPECT_EQ(visited, ivox.size());
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

// SpatialIndex implementations against a brute-force nearest-neighbour oracle. The suite is
// parameterised by the index type name given to make_spatial_index(), so that every index type
// (ivox today; kdtree, voxel_grid later) runs the same checks.
#include "fuse/association/spatial_index.hpp"

#include <gtest/gtest.h>

#include <random>

#include "oracle.hpp"

namespace fuse {
namespace {

constexpr double kVoxel = 0.5;  // a power of two: voxel keys are exact in float
constexpr int kCloudPoints = 20000;
constexpr float kCloudHalf = 5.0f;
constexpr int kQueries = 400;

class SpatialIndexTest : public ::testing::TestWithParam<std::string> {
 protected:
  std::unique_ptr<SpatialIndex> make(const std::string& neighborhood = "nearby26") const {
    SpatialIndexConfig cfg;
    cfg.type = GetParam();
    cfg.voxel_size = kVoxel;
    cfg.neighborhood = neighborhood;
    return make_spatial_index(cfg);
  }
  /// Queries: random positions plus positions on stored points (distance 0).
  static std::vector<Eigen::Vector3f> queries(const std::vector<Eigen::Vector3f>& cloud, std::mt19937& rng) {
    std::vector<Eigen::Vector3f> q = test::random_cloud(rng, kQueries, kCloudHalf + 0.5f);
    for (int i = 0; i < kQueries / 4; ++i) q.push_back(cloud[static_cast<std::size_t>(i) * 37]);
    return q;
  }
};

TEST_P(SpatialIndexTest, FactoryMakesTheNamedType) { EXPECT_EQ(make()->name(), GetParam()); }

TEST_P(SpatialIndexTest, SizeAndIterationCoverInsertedPoints) {
  std::mt19937 rng(70);
  const auto cloud = test::random_cloud(rng, kCloudPoints, kCloudHalf);
  auto index = make();
  index->insert(cloud);
  EXPECT_EQ(index->size(), cloud.size());
  std::size_t visited = 0;
  index->for_each_point([&](const Eigen::Vector3f&) { ++visited; });
  EXPECT_EQ(visited, cloud.size());
}

// Within a radius of one voxel every neighbour lies in the query voxel or one of its 26 neighbours,
// so with nearby26 the result must equal the exhaustive search exactly (k = 1, 5, 10).
TEST_P(SpatialIndexTest, KnnMatchesBruteForceWithinOneVoxel) {
  std::mt19937 rng(71);
  const auto cloud = test::random_cloud(rng, kCloudPoints, kCloudHalf);
  auto index = make("nearby26");
  index->insert(cloud);
  ASSERT_EQ(index->size(), cloud.size());  // nothing refused (max_points_per_voxel)
  const float max_dist = static_cast<float>(kVoxel);
  Neighbors nb;
  for (int k : {1, 5, 10}) {
    for (const Eigen::Vector3f& q : queries(cloud, rng)) {
      const std::vector<float> truth = test::brute_force_knn(cloud, q, k, max_dist);
      index->knn(q, k, max_dist, nb);
      ASSERT_EQ(nb.count, static_cast<int>(truth.size())) << "k " << k << " q " << q.transpose();
      for (int i = 0; i < nb.count; ++i) {
        EXPECT_FLOAT_EQ(nb.dist2[i], truth[static_cast<std::size_t>(i)]) << "k " << k << " rank " << i;
        EXPECT_FLOAT_EQ((nb.points[i] - q).squaredNorm(), nb.dist2[i]);
      }
    }
  }
}

// Smaller neighbourhoods may miss points, but what they return is a sorted subset of the cloud:
// the i-th distance is never below the true i-th distance.
TEST_P(SpatialIndexTest, SmallerNeighbourhoodsReturnValidSubsets) {
  std::mt19937 rng(72);
  const auto cloud = test::random_cloud(rng, kCloudPoints / 4, kCloudHalf);
  constexpr int kK = 8;
  constexpr float kMaxDist = 2.0f;
  for (const char* hood : {"center", "nearby6", "nearby18"}) {
    auto index = make(hood);
    index->insert(cloud);
    Neighbors nb;
    for (const Eigen::Vector3f& q : queries(cloud, rng)) {
      const std::vector<float> truth = test::brute_force_knn(cloud, q, kK, kMaxDist);
      index->knn(q, kK, kMaxDist, nb);
      ASSERT_LE(nb.count, static_cast<int>(truth.size()));
      for (int i = 0; i < nb.count; ++i) {
        EXPECT_GE(nb.dist2[i], truth[static_cast<std::size_t>(i)]) << hood;
        EXPECT_LE(nb.dist2[i], kMaxDist * kMaxDist) << hood;
        if (i > 0) {
          EXPECT_LE(nb.dist2[i - 1], nb.dist2[i]) << hood;
        }
      }
    }
  }
}

// trim() keeps exactly the points inside the axis-aligned box.
TEST_P(SpatialIndexTest, TrimRemovesPointsOutsideTheBox) {
  std::mt19937 rng(73);
  const auto cloud = test::random_cloud(rng, kCloudPoints, kCloudHalf);
  auto index = make();
  index->insert(cloud);
  const Eigen::Vector3f center(1.0f, -0.5f, 0.3f);
  constexpr float kHalf = 2.2f;
  index->trim(center, kHalf);
  std::size_t inside = 0;
  for (const auto& p : cloud) inside += ((p - center).cwiseAbs().array() <= kHalf).all() ? 1 : 0;
  EXPECT_EQ(index->size(), inside);
  std::size_t visited = 0;
  index->for_each_point([&](const Eigen::Vector3f& p) {
    ++visited;
    EXPECT_TRUE(((p - center).cwiseAbs().array() <= kHalf).all()) << p.transpose();
  });
  EXPECT_EQ(visited, inside);
  Neighbors nb;
  index->knn(Eigen::Vector3f(4.5f, 4.5f, 4.5f), 5, 1.0f, nb);  // a corner that was trimmed away
  EXPECT_EQ(nb.count, 0);
}

TEST_P(SpatialIndexTest, EmptyIndexFindsNothing) {
  auto index = make();
  Neighbors nb;
  index->knn(Eigen::Vector3f::Zero(), 5, 10.0f, nb);
  EXPECT_EQ(nb.count, 0);
  EXPECT_EQ(index->size(), 0u);
}

INSTANTIATE_TEST_SUITE_P(Indexes, SpatialIndexTest, ::testing::Values(std::string("ivox")),
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

TEST(SpatialIndexFactory, UnknownTypeIsRefused) {
  SpatialIndexConfig cfg;
  cfg.type = "octree_of_dreams";
  EXPECT_THROW(make_spatial_index(cfg), ConfigError);
  ConfigNode node = ConfigNode::from_string("type: ivox\nneighborhood: nearby99\n");
  EXPECT_THROW(cfg.load(node), ConfigError);
}

}  // namespace
}  // namespace fuse

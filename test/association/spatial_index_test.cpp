// SpatialIndex implementations against a brute-force nearest-neighbour oracle. The suite is
// parameterised by the index type name given to make_spatial_index(), so that every index type
// (ivox, kdtree, voxel_grid) runs the same checks. kdtree and voxel_grid are exact at any radius;
// iVox is exact only within the radius its neighbourhood covers (one voxel with nearby26).
#include "fuse/association/spatial_index.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <random>

#include "fuse/association/kdtree_index.hpp"

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
  /// The largest search radius at which this type must match the oracle exactly.
  static float exact_radius() { return GetParam() == "ivox" ? static_cast<float>(kVoxel) : 2.5f; }
  /// Asserts that knn equals the exhaustive search over cloud for every query.
  static void expect_matches_oracle(const SpatialIndex& index, const std::vector<Eigen::Vector3f>& cloud,
                                    const std::vector<Eigen::Vector3f>& qs, int k, float max_dist) {
    Neighbors nb;
    for (const Eigen::Vector3f& q : qs) {
      const std::vector<float> truth = test::brute_force_knn(cloud, q, k, max_dist);
      index.knn(q, k, max_dist, nb);
      ASSERT_EQ(nb.count, static_cast<int>(truth.size())) << "k " << k << " r " << max_dist << " q " << q.transpose();
      for (int i = 0; i < nb.count; ++i) {
        ASSERT_FLOAT_EQ(nb.dist2[i], truth[static_cast<std::size_t>(i)]) << "k " << k << " rank " << i;
        ASSERT_FLOAT_EQ((nb.points[i] - q).squaredNorm(), nb.dist2[i]);
      }
    }
  }
  /// The stored points, sorted lexicographically (to compare multisets).
  static std::vector<std::array<float, 3>> contents(const SpatialIndex& index) {
    std::vector<std::array<float, 3>> out;
    index.for_each_point([&](const Eigen::Vector3f& p) { out.push_back({p.x(), p.y(), p.z()}); });
    std::sort(out.begin(), out.end());
    return out;
  }
  static std::vector<std::array<float, 3>> sorted(const std::vector<Eigen::Vector3f>& cloud) {
    std::vector<std::array<float, 3>> out;
    for (const auto& p : cloud) out.push_back({p.x(), p.y(), p.z()});
    std::sort(out.begin(), out.end());
    return out;
  }
  static bool inside(const Eigen::Vector3f& p, const Eigen::Vector3f& center, float half) {
    return ((p - center).cwiseAbs().array() <= half).all();
  }
  /// Queries: random positions plus positions on stored points (distance 0).
  static std::vector<Eigen::Vector3f> queries(const std::vector<Eigen::Vector3f>& cloud, std::mt19937& rng) {
    std::vector<Eigen::Vector3f> q = test::random_cloud(rng, kQueries, kCloudHalf + 0.5f);
    for (int i = 0; i < kQueries / 4; ++i) q.push_back(cloud[static_cast<std::size_t>(i) * 37 % cloud.size()]);
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

// Exact types at several radii (including radii beyond one voxel), iVox within one voxel.
TEST_P(SpatialIndexTest, KnnMatchesBruteForceWithinTheExactRadius) {
  std::mt19937 rng(74);
  const auto cloud = test::random_cloud(rng, kCloudPoints / 2, kCloudHalf);
  auto index = make("nearby26");
  index->insert(cloud);
  ASSERT_EQ(index->size(), cloud.size());
  const auto qs = queries(cloud, rng);
  for (float r : {0.1f, 0.5f, 1.5f, 2.5f}) {
    if (r > exact_radius()) continue;
    for (int k : {1, 5, 16}) expect_matches_oracle(*index, cloud, qs, k, r);
  }
}

// A sparse cloud: few neighbours within the radius, so searches run to the radius bound.
TEST_P(SpatialIndexTest, KnnMatchesBruteForceOnASparseCloud) {
  std::mt19937 rng(75);
  const auto cloud = test::random_cloud(rng, 300, 20.0f);
  auto index = make("nearby26");
  index->insert(cloud);
  const auto qs = queries(cloud, rng);
  expect_matches_oracle(*index, cloud, qs, 5, exact_radius());
  expect_matches_oracle(*index, cloud, qs, 3, 0.3f);
}

// A map grown scan by scan: batches that move along x (new space) and overlap the previous ones.
TEST_P(SpatialIndexTest, IncrementalInsertsMatchBruteForce) {
  std::mt19937 rng(76);
  auto index = make("nearby26");
  std::vector<Eigen::Vector3f> all;
  for (int batch = 0; batch < 12; ++batch) {
    auto pts = test::random_cloud(rng, 1500, 3.0f);
    for (auto& p : pts) p.x() += 1.5f * static_cast<float>(batch);
    index->insert(pts);
    all.insert(all.end(), pts.begin(), pts.end());
    ASSERT_EQ(index->size(), all.size()) << "batch " << batch;
    if (batch % 4 == 3) {
      std::vector<Eigen::Vector3f> qs = test::random_cloud(rng, 150, 3.5f);
      for (auto& q : qs) q.x() += 0.75f * static_cast<float>(batch);
      for (int i = 0; i < 50; ++i) qs.push_back(all[static_cast<std::size_t>(i) * 97 % all.size()]);
      expect_matches_oracle(*index, all, qs, 5, exact_radius());
    }
  }
  EXPECT_EQ(contents(*index), sorted(all));
}

// Every stored point is found by a query on it, across the hash tables' growth (regression: a
// voxel created by the point that made the table grow was dropped from the table, so the next
// point of that voxel made a duplicate record and the first became unreachable).
TEST_P(SpatialIndexTest, EveryInsertedPointIsFound) {
  std::mt19937 rng(82);
  auto index = make("center");
  std::vector<Eigen::Vector3f> all;
  for (int batch = 0; batch < 4; ++batch) {
    const auto pts = test::random_cloud(rng, 5000, 8.0f);
    index->insert(pts);
    all.insert(all.end(), pts.begin(), pts.end());
  }
  ASSERT_EQ(index->size(), all.size());
  Neighbors nb;
  for (const Eigen::Vector3f& p : all) {
    index->knn(p, 1, 1e-3f, nb);
    ASSERT_EQ(nb.count, 1) << p.transpose();
    ASSERT_EQ(nb.dist2[0], 0.0f);
  }
}

// Single points inserted one at a time (the kd-tree splits leaves and rebalances).
TEST_P(SpatialIndexTest, OnePointAtATime) {
  std::mt19937 rng(77);
  const auto cloud = test::random_cloud(rng, 3000, 4.0f);
  auto index = make("nearby26");
  for (const auto& p : cloud) index->insert({p});
  ASSERT_EQ(index->size(), cloud.size());
  EXPECT_EQ(contents(*index), sorted(cloud));
  expect_matches_oracle(*index, cloud, queries(cloud, rng), 5, exact_radius());
}

// After trim the index answers like the oracle over the points inside the box, and further
// inserts and trims (a sliding window) keep it consistent.
TEST_P(SpatialIndexTest, TrimThenKnnMatchesBruteForce) {
  std::mt19937 rng(78);
  auto index = make("nearby26");
  std::vector<Eigen::Vector3f> all;
  for (int step = 0; step < 6; ++step) {
    auto pts = test::random_cloud(rng, 4000, kCloudHalf);
    for (auto& p : pts) p.x() += 2.0f * static_cast<float>(step);
    index->insert(pts);
    all.insert(all.end(), pts.begin(), pts.end());
    const Eigen::Vector3f center(2.0f * static_cast<float>(step) + 0.3f, -0.7f, 0.4f);
    const float half = 3.7f;
    index->trim(center, half);
    all.erase(std::remove_if(all.begin(), all.end(), [&](const Eigen::Vector3f& p) { return !inside(p, center, half); }),
              all.end());
    ASSERT_EQ(index->size(), all.size()) << "step " << step;
    ASSERT_EQ(contents(*index), sorted(all)) << "step " << step;
    std::vector<Eigen::Vector3f> qs = test::random_cloud(rng, 200, half + 1.0f);
    for (auto& q : qs) q += center;
    expect_matches_oracle(*index, all, qs, 5, exact_radius());
  }
  index->trim(Eigen::Vector3f(100.0f, 100.0f, 100.0f), 1.0f);  // everything outside
  EXPECT_EQ(index->size(), 0u);
  Neighbors nb;
  index->knn(Eigen::Vector3f::Zero(), 5, 10.0f, nb);
  EXPECT_EQ(nb.count, 0);
  const auto again = test::random_cloud(rng, 500, 2.0f);  // usable after being emptied
  index->insert(again);
  EXPECT_EQ(index->size(), again.size());
  expect_matches_oracle(*index, again, queries(again, rng), 5, exact_radius());
}

// erase takes out exactly the stored points equal to the given ones (every copy), ignores points
// not stored, and leaves an index that answers like the oracle over what remains; rounds of
// inserts and erases (a map policy taking back points) keep it so, down to empty and back.
TEST_P(SpatialIndexTest, EraseThenKnnMatchesBruteForce) {
  std::mt19937 rng(91);
  auto index = make("nearby26");
  std::vector<Eigen::Vector3f> all;
  for (int round = 0; round < 5; ++round) {
    const auto pts = test::random_cloud(rng, 3000, kCloudHalf);
    index->insert(pts);
    all.insert(all.end(), pts.begin(), pts.end());
    // Every third stored point, a copy of one of them inserted twice, and points never stored.
    std::vector<Eigen::Vector3f> gone;
    for (std::size_t i = static_cast<std::size_t>(round); i < all.size(); i += 3) gone.push_back(all[i]);
    index->insert({gone.front()});
    all.push_back(gone.front());
    std::vector<Eigen::Vector3f> request = gone;
    request.push_back(Eigen::Vector3f(100.0f, 100.0f, 100.0f));
    request.push_back(gone.front() + Eigen::Vector3f(1e-3f, 0.0f, 0.0f));
    const std::size_t before = all.size();
    const auto erased = [&](const Eigen::Vector3f& p) {
      return std::find(gone.begin(), gone.end(), p) != gone.end();
    };
    all.erase(std::remove_if(all.begin(), all.end(), erased), all.end());
    ASSERT_EQ(index->erase(request), before - all.size()) << "round " << round;
    ASSERT_EQ(index->size(), all.size()) << "round " << round;
    ASSERT_EQ(contents(*index), sorted(all)) << "round " << round;
    expect_matches_oracle(*index, all, queries(all, rng), 5, exact_radius());
  }
  std::vector<Eigen::Vector3f> everything = all;
  EXPECT_EQ(index->erase(everything), all.size());
  EXPECT_EQ(index->size(), 0u);
  Neighbors nb;
  index->knn(Eigen::Vector3f::Zero(), 5, 10.0f, nb);
  EXPECT_EQ(nb.count, 0);
  const auto again = test::random_cloud(rng, 500, 2.0f);  // usable after being emptied
  index->insert(again);
  EXPECT_EQ(contents(*index), sorted(again));
  expect_matches_oracle(*index, again, queries(again, rng), 5, exact_radius());
}

// Coincident points (a voxel's capacity is raised so that voxel types keep them all).
TEST_P(SpatialIndexTest, CoincidentPoints) {
  SpatialIndexConfig cfg;
  cfg.type = GetParam();
  cfg.voxel_size = kVoxel;
  cfg.neighborhood = "nearby26";
  cfg.max_points_per_voxel = 1000;
  auto index = make_spatial_index(cfg);
  std::vector<Eigen::Vector3f> cloud(300, Eigen::Vector3f(0.1f, 0.2f, 0.3f));
  std::mt19937 rng(79);
  const auto noise = test::random_cloud(rng, 200, 1.0f);
  index->insert(cloud);
  index->insert(noise);
  cloud.insert(cloud.end(), noise.begin(), noise.end());
  ASSERT_EQ(index->size(), cloud.size());
  expect_matches_oracle(*index, cloud, queries(cloud, rng), 16, exact_radius());
}

TEST_P(SpatialIndexTest, EmptyIndexFindsNothing) {
  auto index = make();
  Neighbors nb;
  index->knn(Eigen::Vector3f::Zero(), 5, 10.0f, nb);
  EXPECT_EQ(nb.count, 0);
  EXPECT_EQ(index->size(), 0u);
}

INSTANTIATE_TEST_SUITE_P(Indexes, SpatialIndexTest, ::testing::Values(std::string("ivox"), std::string("kdtree"), std::string("voxel_grid")),
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

TEST(SpatialIndexFactory, UnknownTypeIsRefused) {
  SpatialIndexConfig cfg;
  cfg.type = "octree_of_dreams";
  EXPECT_THROW(make_spatial_index(cfg), ConfigError);
  ConfigNode node = ConfigNode::from_string("type: ivox\nneighborhood: nearby99\n");
  EXPECT_THROW(cfg.load(node), ConfigError);
}

TEST(SpatialIndexFactory, ConfigAcceptsEveryTypeAndNamesTheKeyOfAnUnknownOne) {
  for (const char* type : {"ivox", "kdtree", "voxel_grid"}) {
    SpatialIndexConfig cfg;
    ConfigNode node(YAML::Load(std::string("type: ") + type + "\n"), "estimator.spatial_index");
    cfg.load(node);
    EXPECT_EQ(cfg.type, type);
    EXPECT_EQ(make_spatial_index(cfg)->name(), type);
  }
  SpatialIndexConfig cfg;
  ConfigNode node(YAML::Load("type: octree\n"), "estimator.spatial_index");
  try {
    cfg.load(node);
    FAIL() << "unknown type accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("estimator.spatial_index.type"), std::string::npos) << e.what();
  }
}

// The kd-tree stays shallow when the map grows along one direction, batch after batch.
TEST(KdTreeIndex, StaysBalancedWhileTheMapGrowsAlongALine) {
  KdTreeIndex tree{SpatialIndexConfig{}};
  std::mt19937 rng(81);
  for (int batch = 0; batch < 200; ++batch) {
    auto pts = test::random_cloud(rng, 1000, 2.0f);
    for (auto& p : pts) p.x() += 0.5f * static_cast<float>(batch);
    tree.insert(pts);
  }
  ASSERT_EQ(tree.size(), 200000u);
  // A balanced tree of 200000 points in leaves of ≤ 32 has depth ≈ 13; allow the α slack.
  EXPECT_LE(tree.depth(), 30);
  tree.trim(Eigen::Vector3f(50.0f, 0.0f, 0.0f), 10.0f);
  EXPECT_LE(tree.depth(), 30);
}

}  // namespace
}  // namespace fuse

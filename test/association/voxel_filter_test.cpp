// VoxelFilter (voxel_filter.hpp) against an exhaustive oracle: one point per occupied voxel, the
// one closest to the voxel centre, indices in input order.
#include "fuse/association/voxel_filter.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <tuple>

#include "oracle.hpp"

namespace fuse {
namespace {

constexpr double kVoxel = 0.5;  // a power of two: the cell of a point is exact in float

std::vector<std::uint32_t> oracle_filter(const std::vector<Eigen::Vector3f>& points, double voxel) {
  std::map<std::tuple<long, long, long>, std::pair<double, std::uint32_t>> best;
  for (std::uint32_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d p = points[i].cast<double>();
    const Eigen::Vector3d cell = (p / voxel).array().floor();
    const double d2 = (p - (cell.array() + 0.5).matrix() * voxel).squaredNorm();
    const auto key = std::make_tuple(static_cast<long>(cell.x()), static_cast<long>(cell.y()), static_cast<long>(cell.z()));
    auto it = best.find(key);
    if (it == best.end() || d2 < it->second.first) best[key] = {d2, i};
  }
  std::vector<std::uint32_t> kept;
  for (const auto& kv : best) kept.push_back(kv.second.second);
  std::sort(kept.begin(), kept.end());
  return kept;
}

TEST(VoxelFilter, KeepsThePointClosestToEachVoxelCentre) {
  std::mt19937 rng(90);
  VoxelFilter filter;
  for (int n : {0, 1, 100, 20000}) {
    const auto cloud = test::random_cloud(rng, n, 3.0f);  // ~ 1700 voxels: many points per voxel
    std::vector<std::uint32_t> kept;
    filter.filter(cloud, static_cast<float>(kVoxel), kept);
    EXPECT_EQ(kept, oracle_filter(cloud, kVoxel)) << "n = " << n;
  }
}

// Reusing the filter (its table is kept between calls) gives the same answer as a fresh one.
TEST(VoxelFilter, ReuseGivesTheSameResult) {
  std::mt19937 rng(91);
  const auto big = test::random_cloud(rng, 5000, 10.0f);
  const auto small = test::random_cloud(rng, 300, 2.0f);
  VoxelFilter reused, fresh;
  const auto voxel = static_cast<float>(kVoxel);
  std::vector<std::uint32_t> a, b;
  reused.filter(big, voxel, a);
  reused.filter(small, voxel, a);
  fresh.filter(small, voxel, b);
  EXPECT_EQ(a, b);
}

// A filter whose memory was reserved ahead (reserve()) filters exactly as one that grows as it
// goes, for clouds smaller and larger than the reservation.
TEST(VoxelFilter, ReservedFilterMatchesTheOracle) {
  std::mt19937 rng(92);
  VoxelFilter filter;
  filter.reserve(2000);
  for (int n : {50, 2000, 30000, 10}) {
    const auto cloud = test::random_cloud(rng, n, 8.0f);
    std::vector<std::uint32_t> kept;
    filter.filter(cloud, static_cast<float>(kVoxel), kept);
    EXPECT_EQ(kept, oracle_filter(cloud, kVoxel)) << "n = " << n;
  }
}

// Points in scan order (a spinning LiDAR's rings: consecutive points a few centimetres apart, many
// in one voxel, runs broken and resumed) keep what the oracle keeps, ties included: two points
// at the same place, the first stays.
TEST(VoxelFilter, ScanOrderedPointsMatchTheOracle) {
  std::mt19937 rng(93);
  std::normal_distribution<float> noise(0.0f, 0.02f);
  std::vector<Eigen::Vector3f> rings;
  for (int ring = 0; ring < 16; ++ring) {
    const float elevation = -0.26f + 0.035f * static_cast<float>(ring);
    for (int col = 0; col < 1024; ++col) {
      const float azimuth = 2.0f * static_cast<float>(M_PI) * static_cast<float>(col) / 1024.0f;
      const float range = 6.0f + 2.0f * std::sin(3.0f * azimuth) + noise(rng);
      const Eigen::Vector3f p(range * std::cos(elevation) * std::cos(azimuth), range * std::cos(elevation) * std::sin(azimuth),
                              range * std::sin(elevation));
      rings.push_back(p);
      if (col % 7 == 0) rings.push_back(p);  // a repeated return: a tie
    }
  }
  VoxelFilter filter;
  std::vector<std::uint32_t> kept;
  filter.filter(rings, static_cast<float>(kVoxel), kept);
  EXPECT_EQ(kept, oracle_filter(rings, kVoxel));
  EXPECT_LT(kept.size(), rings.size() / 4);  // many points per voxel: runs were reused
}

}  // namespace
}  // namespace fuse

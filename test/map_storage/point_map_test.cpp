// Chunked point map (point_map.hpp): key packing with negative coordinates, chunk assignment,
// revisions and the keys of changed chunks.
#include "fuse/map/point_map.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>

namespace fuse {
namespace {

TEST(PointMap, KeyPackingRoundTripsIncludingNegatives) {
  const Eigen::Vector3i coords[] = {{0, 0, 0},
                                    {1, 2, 3},
                                    {-1, -1, -1},
                                    {-5, 7, -9},
                                    {PointMap::kCoordMin, PointMap::kCoordMax, 0},
                                    {PointMap::kCoordMax, PointMap::kCoordMin, -1}};
  for (const Eigen::Vector3i& c : coords) {
    const std::uint64_t key = PointMap::pack_key(c);
    EXPECT_EQ(PointMap::unpack_key(key), c) << c.transpose();
    EXPECT_EQ(key >> 63, 0u);
  }
  // Documented layout: biased by 2^20, x in the top 21 bits, z in the bottom 21 bits.
  EXPECT_EQ(PointMap::pack_key({0, 0, 0}), (1ull << 20) << 42 | (1ull << 20) << 21 | (1ull << 20));
  EXPECT_EQ(PointMap::pack_key({-1, 0, 0}), ((1ull << 20) - 1) << 42 | (1ull << 20) << 21 | (1ull << 20));
  // Neighbouring coordinates give distinct keys (no sign-extension aliasing).
  EXPECT_NE(PointMap::pack_key({-1, 0, 0}), PointMap::pack_key({0, -1, 0}));
  EXPECT_NE(PointMap::pack_key({0, 0, -1}), PointMap::pack_key({0, -1, 0}));
  EXPECT_THROW(PointMap::pack_key({PointMap::kCoordMax + 1, 0, 0}), std::out_of_range);
  EXPECT_THROW(PointMap::pack_key({0, 0, PointMap::kCoordMin - 1}), std::out_of_range);
}

TEST(PointMap, PointsGoToTheChunkOfTheirFlooredCoordinates) {
  PointMap map(20.0);
  EXPECT_EQ(map.coord_of({0.f, 19.9f, 20.f}), Eigen::Vector3i(0, 0, 1));
  EXPECT_EQ(map.coord_of({-0.01f, -20.f, -20.01f}), Eigen::Vector3i(-1, -1, -2));

  const auto changed = map.insert({{1, 1, 1}, {-1, 1, 1}, {2, 2, 2}, {-1, -1, -41}});
  ASSERT_EQ(changed.size(), 3u);
  EXPECT_TRUE(std::is_sorted(changed.begin(), changed.end()));
  EXPECT_EQ(map.num_chunks(), 3u);
  EXPECT_EQ(map.num_points(), 4u);
  const PointChunk* origin = map.chunk(PointMap::pack_key({0, 0, 0}));
  ASSERT_NE(origin, nullptr);
  EXPECT_EQ(origin->points.size(), 2u);
  EXPECT_EQ(origin->revision, 1u);
  const PointChunk* deep = map.chunk(PointMap::pack_key({-1, -1, -3}));
  ASSERT_NE(deep, nullptr);
  EXPECT_EQ(deep->coord, Eigen::Vector3i(-1, -1, -3));
}

TEST(PointMap, RevisionsCountChangesAndOnlyChangedChunksAreReported) {
  PointMap map(10.0);
  map.insert({{1, 1, 1}, {15, 1, 1}});
  // Two points in the same chunk, interleaved with another chunk: one revision step each.
  const auto changed = map.insert({{2, 2, 2}, {25, 0, 0}, {3, 3, 3}});
  ASSERT_EQ(changed.size(), 2u);
  EXPECT_EQ(map.chunk(PointMap::pack_key({0, 0, 0}))->revision, 2u);
  EXPECT_EQ(map.chunk(PointMap::pack_key({1, 0, 0}))->revision, 1u);
  EXPECT_EQ(map.chunk(PointMap::pack_key({2, 0, 0}))->revision, 1u);
  EXPECT_TRUE(map.insert({}).empty());
}

TEST(PointMap, RefusesNonFiniteAndUnrepresentablePoints) {
  PointMap map(1.0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(map.insertable({nan, 0, 0}));
  EXPECT_FALSE(map.insertable({0, std::numeric_limits<float>::infinity(), 0}));
  EXPECT_FALSE(map.insertable({0, 0, 3.0e6f}));
  EXPECT_FALSE(map.insertable({-3.0e38f, 0, 0}));
  EXPECT_TRUE(map.insertable({-1.0e6f, 1.0e6f, 0}));
  EXPECT_EQ(map.insert({{nan, 0, 0}, {0, 0, 3.0e6f}}).size(), 0u);
  EXPECT_EQ(map.num_points(), 0u);
}

TEST(PointMap, ForEachChunkVisitsAscendingKeysAndClearEmpties) {
  PointMap map(5.0);
  map.insert({{-12, 0, 0}, {30, 0, 0}, {0, 0, 0}, {0, -7, 3}});
  std::uint64_t previous = 0;
  std::size_t points = 0, chunks = 0;
  map.for_each_chunk([&](const PointChunk& c) {
    EXPECT_GT(c.key, previous);
    EXPECT_EQ(PointMap::unpack_key(c.key), c.coord);
    previous = c.key;
    points += c.points.size();
    ++chunks;
  });
  EXPECT_EQ(points, 4u);
  EXPECT_EQ(chunks, map.num_chunks());
  map.clear();
  EXPECT_EQ(map.num_chunks(), 0u);
  EXPECT_EQ(map.num_points(), 0u);
}

TEST(PointMap, PutChunkValidatesKeyAndPoints) {
  PointMap map(10.0);
  PointChunk chunk;
  chunk.coord = {-1, 0, 2};
  chunk.key = PointMap::pack_key(chunk.coord);
  chunk.revision = 7;
  chunk.points = {{-5, 5, 25}, {-0.5f, 9.5f, 29}};
  EXPECT_TRUE(map.put_chunk(chunk));
  EXPECT_EQ(map.num_points(), 2u);
  EXPECT_EQ(map.chunk(chunk.key)->revision, 7u);

  PointChunk wrong_key = chunk;
  wrong_key.key += 1;
  EXPECT_FALSE(map.put_chunk(wrong_key));
  PointChunk stray_point = chunk;
  stray_point.points.push_back({5, 5, 25});  // belongs to chunk (0, 0, 2)
  EXPECT_FALSE(map.put_chunk(stray_point));
  EXPECT_EQ(map.num_points(), 2u);
  EXPECT_THROW(PointMap(0.0), std::invalid_argument);
}

}  // namespace
}  // namespace fuse

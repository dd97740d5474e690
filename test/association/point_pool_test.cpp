// PointPool (point_pool.hpp) and the huge-page memory under it (huge_page_memory.hpp): chunk
// sizes double up to the voxel limit, chunks never overlap, a released chunk is reused by the next
// request of its size, blocks are taken one at a time, and a reserve is used before new blocks.
#include "fuse/association/point_pool.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <set>
#include <utility>

namespace fuse {
namespace {

TEST(HugePageRegion, IsAlignedZeroFilledAndMovable) {
  HugePageRegion region(kHugePage + 1);
  ASSERT_NE(region.data(), nullptr);
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(region.data()) % kHugePage, 0u);
  EXPECT_EQ(region.size(), 2 * kHugePage);  // whole huge pages
  touch_pages(region.data(), region.size());
  for (std::size_t i = 0; i < region.size(); i += 4093) ASSERT_EQ(region.data()[i], 0) << i;
  region.data()[region.size() - 1] = 7;
  HugePageRegion moved(std::move(region));
  EXPECT_EQ(region.data(), nullptr);  // NOLINT(bugprone-use-after-move): moved-from is empty by contract
  EXPECT_EQ(moved.data()[moved.size() - 1], 7);
}

TEST(PointPool, ChunkSizesDoubleUpToTheLimit) {
  PointPool pool(64);
  for (auto [wanted, capacity] : {std::pair<std::size_t, std::uint32_t>{1, 8}, {8, 8}, {9, 16}, {17, 32}, {33, 64}, {64, 64}, {500, 64}}) {
    const PointPool::Chunk c = pool.allocate(wanted);
    EXPECT_EQ(c.capacity, capacity) << "for " << wanted << " points";
  }
  PointPool odd(20);  // the last size is the limit itself
  EXPECT_EQ(odd.allocate(17).capacity, 20u);
  PointPool tiny(3);  // below the smallest chunk: one size
  EXPECT_EQ(tiny.allocate(1).capacity, 3u);
  EXPECT_THROW(PointPool(0), std::invalid_argument);
}

TEST(PointPool, ChunksDoNotOverlapAndFreedOnesAreReused) {
  PointPool pool(64);
  std::set<std::pair<std::uintptr_t, std::uintptr_t>> ranges;  // [begin, end) of every chunk handed out
  std::vector<PointPool::Chunk> chunks;
  for (int i = 0; i < 30000; ++i) {  // 10,000 chunks of 32 points (5,461 per block), 20,000 of 8 (21,845)
    const PointPool::Chunk c = pool.allocate(i % 3 == 0 ? 20 : 5);
    const auto begin = reinterpret_cast<std::uintptr_t>(c.data);
    const std::uintptr_t end = begin + c.capacity * sizeof(Eigen::Vector3f);
    const auto next = ranges.lower_bound({begin, 0});
    ASSERT_TRUE(next == ranges.end() || next->first >= end) << "chunk " << i << " overlaps the next";
    ASSERT_TRUE(next == ranges.begin() || std::prev(next)->second <= begin) << "chunk " << i << " overlaps the previous";
    ranges.emplace(begin, end);
    for (std::uint32_t k = 0; k < c.capacity; ++k) c.data[k] = Eigen::Vector3f::Constant(static_cast<float>(i));  // writable
    chunks.push_back(c);
  }
  EXPECT_EQ(pool.num_blocks(), 3u);  // 32-point chunks: two blocks; 8-point chunks: one
  pool.release(chunks[1]);
  EXPECT_EQ(pool.num_free(8), 1u);
  EXPECT_EQ(pool.allocate(8).data, chunks[1].data);
  EXPECT_EQ(pool.num_free(8), 0u);
  EXPECT_THROW(pool.release(PointPool::Chunk{chunks[2].data, 12}), std::logic_error);
}

TEST(PointPool, TheReserveServesFirst) {
  PointPool pool(64, 400000);  // 4.8 MB of points: three blocks faulted in now
  EXPECT_EQ(pool.num_ready_blocks(), 3u);
  EXPECT_EQ(pool.num_blocks(), 0u);
  pool.allocate(8);
  pool.allocate(64);
  EXPECT_EQ(pool.num_ready_blocks(), 1u);  // one block per chunk size in use
  EXPECT_EQ(pool.num_blocks(), 2u);
  pool.prepare();  // nothing to map ahead while the reserve lasts
  for (int i = 0; i < 3000; ++i) pool.allocate(64);  // 2,730 per block: a second one
  EXPECT_EQ(pool.num_ready_blocks(), 0u);
  pool.prepare();  // the spare, mapped ahead, is the next block
  for (int i = 0; i < 3000; ++i) pool.allocate(64);
  EXPECT_EQ(pool.num_blocks(), 4u);
}

}  // namespace
}  // namespace fuse

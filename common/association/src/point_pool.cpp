#include "fuse/association/point_pool.hpp"

#include <algorithm>
#include <stdexcept>
#include <utility>

namespace fuse {

namespace {
/// Capacity of the smallest chunk: most voxels of a scan's map hold a few points.
constexpr std::uint32_t kSmallestChunk = 8;
/// A block is one huge page: 2,730 chunks of 64 points (the default config's limit), 21,845 of 8.
constexpr std::size_t kBlockBytes = kHugePage;
/// Bytes of the spare block faulted in per prepare(): in huge pages the first write takes the
/// whole page in one fault (~0.1 ms); in 4 KiB pages 128 KiB is 32 faults (~0.4 ms measured on a
/// virtual machine), so a block is spread over 16 batches.
constexpr std::size_t kTouchPerPrepare = std::size_t{128} << 10;
}  // namespace

PointPool::PointPool(std::size_t max_points, std::size_t reserve_points) {
  if (max_points == 0) throw std::invalid_argument("PointPool: max_points must be at least 1");
  std::size_t capacity = std::min<std::size_t>(kSmallestChunk, max_points);
  for (;;) {
    classes_.push_back(SizeClass{static_cast<std::uint32_t>(capacity), {}, nullptr, nullptr});
    if (capacity >= max_points) break;
    capacity = std::min(capacity * 2, max_points);
  }
  const std::size_t reserve_blocks = huge_page_round_up(reserve_points * sizeof(Eigen::Vector3f)) / kBlockBytes;
  ready_.reserve(reserve_blocks);
  for (std::size_t i = 0; i < reserve_blocks; ++i) {
    ready_.emplace_back(kBlockBytes);
    touch_pages(ready_.back().data(), kBlockBytes);
  }
}

PointPool::SizeClass& PointPool::class_for(std::size_t points) {
  for (SizeClass& c : classes_) {
    if (c.capacity >= points) return c;
  }
  return classes_.back();
}

PointPool::Chunk PointPool::allocate(std::size_t points) {
  SizeClass& c = class_for(points);
  if (!c.free.empty()) {
    Eigen::Vector3f* data = c.free.back();
    c.free.pop_back();
    return {data, c.capacity};
  }
  const std::size_t bytes = c.capacity * sizeof(Eigen::Vector3f);
  if (c.next == nullptr || static_cast<std::size_t>(c.end - c.next) < bytes) {
    const std::size_t block = std::max(kBlockBytes, huge_page_round_up(bytes));
    c.next = take_block(block);
    c.end = c.next + block;
  }
  auto* data = reinterpret_cast<Eigen::Vector3f*>(c.next);
  c.next += bytes;
  return {data, c.capacity};
}

void PointPool::release(const Chunk& chunk) {
  if (chunk.data == nullptr) return;
  for (SizeClass& c : classes_) {
    if (c.capacity == chunk.capacity) {
      c.free.push_back(chunk.data);
      return;
    }
  }
  throw std::logic_error("PointPool::release: a chunk of a capacity this pool does not make");
}

char* PointPool::take_block(std::size_t bytes) {
  if (!ready_.empty() && ready_.back().size() == bytes) {
    blocks_.push_back(std::move(ready_.back()));
    ready_.pop_back();
  } else if (spare_.data() != nullptr && spare_.size() == bytes) {
    blocks_.push_back(std::move(spare_));
    spare_ = HugePageRegion();
    spare_touched_ = 0;
  } else {
    blocks_.emplace_back(bytes);
  }
  return blocks_.back().data();
}

void PointPool::prepare() {
  if (!ready_.empty()) return;  // the spare is needed only once the reserve is used up
  if (spare_.data() == nullptr) {
    spare_ = HugePageRegion(kBlockBytes);
    spare_touched_ = 0;
  }
  if (spare_touched_ >= spare_.size()) return;
  const std::size_t n = std::min(kTouchPerPrepare, spare_.size() - spare_touched_);
  touch_pages(spare_.data() + spare_touched_, n);
  spare_touched_ += n;
}

std::size_t PointPool::num_free(std::uint32_t capacity) const {
  for (const SizeClass& c : classes_) {
    if (c.capacity == capacity) return c.free.size();
  }
  return 0;
}

}  // namespace fuse

// Memory in transparent huge pages for the map index's large, randomly read arrays (the iVox
// hash table, voxel records and point chunks).
//
// Why: a k-nearest query reads a few voxels scattered over hundreds of megabytes. In 4 KiB pages
// nearly every one of those reads also misses the TLB, and the scans whose voxels lie on the most
// pages are the per-scan tail (docs/performance.md).
//
// Memory touched for the first time costs a fault, and on a virtual machine memory new to the
// process can cost far more than the kernel's work: measured here, 2 MiB in 4 KiB pages takes
// ~7 ms of faults, one 2 MiB huge page 1-5 ms when the memory is new and ~0.12 ms when it is
// not. So what an index will need is faulted in when it is made, not while scans are timed.
//
// MADV_HUGEPAGE is a hint: where transparent huge pages are off, the same memory is served in
// 4 KiB pages and everything works, only slower.
#pragma once

#include <cstddef>
#include <new>

namespace fuse {

/// A transparent huge page (x86-64, and arm64 with 4 KiB base pages).
inline constexpr std::size_t kHugePage = std::size_t{2} << 20;

/// An anonymous mapping of whole huge pages, aligned to kHugePage and advised MADV_HUGEPAGE. The
/// kernel zero-fills it; pages are faulted in on first write.
class HugePageRegion {
 public:
  HugePageRegion() = default;
  /// At least `bytes` (rounded up to whole huge pages). Throws std::bad_alloc.
  explicit HugePageRegion(std::size_t bytes);
  ~HugePageRegion();
  HugePageRegion(HugePageRegion&& other) noexcept;
  HugePageRegion& operator=(HugePageRegion&& other) noexcept;
  HugePageRegion(const HugePageRegion&) = delete;
  HugePageRegion& operator=(const HugePageRegion&) = delete;

  char* data() const { return data_; }
  std::size_t size() const { return size_; }
  /// Takes ownership away: the caller unmaps with unmap_huge_pages(data, size).
  char* release();

 private:
  char* data_ = nullptr;
  std::size_t size_ = 0;
};

/// Bytes rounded up to whole huge pages.
constexpr std::size_t huge_page_round_up(std::size_t bytes) { return (bytes + kHugePage - 1) / kHugePage * kHugePage; }

/// Unmaps what HugePageRegion::release() handed over.
void unmap_huge_pages(char* data, std::size_t bytes);

/// Faults in [begin, begin + bytes) now by writing a zero into each 4 KiB page (a read would only
/// map the shared zero page). For memory not yet written: it stays all zeros.
void touch_pages(char* begin, std::size_t bytes);

/// A std::allocator for containers of records that grow large (the iVox voxel records):
/// allocations of a huge page or more come from huge-page mappings faulted in whole before they
/// are handed out (a reserve() pays for its pages at once), smaller ones from the heap.
template <typename T>
struct HugePageAllocator {
  using value_type = T;
  HugePageAllocator() = default;
  template <typename U>
  HugePageAllocator(const HugePageAllocator<U>&) {}  // NOLINT: rebinding, as std::allocator

  T* allocate(std::size_t n) {
    const std::size_t bytes = n * sizeof(T);
    if (bytes < kHugePage) return static_cast<T*>(::operator new(bytes));
    HugePageRegion region(bytes);
    touch_pages(region.data(), region.size());
    return reinterpret_cast<T*>(region.release());
  }
  void deallocate(T* p, std::size_t n) noexcept {
    const std::size_t bytes = n * sizeof(T);
    if (bytes < kHugePage) {
      ::operator delete(p);
    } else {
      unmap_huge_pages(reinterpret_cast<char*>(p), huge_page_round_up(bytes));
    }
  }
  template <typename U>
  bool operator==(const HugePageAllocator<U>&) const { return true; }
  template <typename U>
  bool operator!=(const HugePageAllocator<U>&) const { return false; }
};

}  // namespace fuse

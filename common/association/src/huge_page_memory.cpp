#include "fuse/association/huge_page_memory.hpp"

#include <cstdint>
#include <utility>

#include <sys/mman.h>

namespace fuse {

namespace {
constexpr std::size_t kBasePage = 4096;
}  // namespace

HugePageRegion::HugePageRegion(std::size_t bytes) {
  // Map one huge page more than needed, then unmap the unaligned head and the tail: what stays is
  // aligned, so the kernel can back every 2 MiB of it with one huge page.
  const std::size_t size = huge_page_round_up(bytes == 0 ? 1 : bytes);
  void* raw = ::mmap(nullptr, size + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) throw std::bad_alloc();
  char* const base = static_cast<char*>(raw);
  const std::uintptr_t addr = reinterpret_cast<std::uintptr_t>(base);
  char* const aligned = base + ((kHugePage - addr % kHugePage) % kHugePage);
  if (aligned > base) ::munmap(base, static_cast<std::size_t>(aligned - base));
  char* const tail = aligned + size;
  if (tail < base + size + kHugePage) ::munmap(tail, static_cast<std::size_t>(base + size + kHugePage - tail));
  ::madvise(aligned, size, MADV_HUGEPAGE);  // a hint: refused, 4 KiB pages serve
  data_ = aligned;
  size_ = size;
}

HugePageRegion::~HugePageRegion() { unmap_huge_pages(data_, size_); }

HugePageRegion::HugePageRegion(HugePageRegion&& other) noexcept
    : data_(std::exchange(other.data_, nullptr)), size_(std::exchange(other.size_, 0)) {}

HugePageRegion& HugePageRegion::operator=(HugePageRegion&& other) noexcept {
  if (this != &other) {
    unmap_huge_pages(data_, size_);
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
  }
  return *this;
}

char* HugePageRegion::release() {
  size_ = 0;
  return std::exchange(data_, nullptr);
}

void unmap_huge_pages(char* data, std::size_t bytes) {
  if (data != nullptr) ::munmap(data, bytes);
}

void touch_pages(char* begin, std::size_t bytes) {
  volatile char* p = begin;
  for (std::size_t i = 0; i < bytes; i += kBasePage) p[i] = 0;
}

}  // namespace fuse

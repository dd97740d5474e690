// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320), the checksum the MCAP format uses for
// chunk records, the data section and the summary section. Incremental: feed bytes in pieces.
#pragma once

#include <cstddef>
#include <cstdint>

namespace fuse::io {

class Crc32 {
 public:
  void update(const void* data, std::size_t size);
  std::uint32_t value() const { return ~state_; }  ///< final XOR applied

 private:
  std::uint32_t state_ = 0xFFFFFFFFu;  ///< initial value of the register
};

/// CRC-32 of one buffer.
std::uint32_t crc32(const void* data, std::size_t size);

}  // namespace fuse::io

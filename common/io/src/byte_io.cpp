#include "fuse/io/byte_io.hpp"

namespace fuse::io {

void ByteReader::fail(const std::string& what) const {
  throw InputError(context_ + ": " + what + " (at byte " + std::to_string(pos_) + " of " + std::to_string(size_) + ")");
}

void ByteReader::require(std::uint64_t n, const char* field) const {
  if (n > size_ - pos_) {
    fail(std::string("truncated ") + field + ": needs " + std::to_string(n) + " bytes, " +
         std::to_string(size_ - pos_) + " left");
  }
}

std::string ByteReader::string(const char* field) {
  const std::uint32_t n = u32();
  const auto* p = bytes(n, field);
  return std::string(reinterpret_cast<const char*>(p), n);
}

const std::uint8_t* ByteReader::bytes(std::uint64_t n, const char* field) {
  require(n, field);
  const std::uint8_t* p = data_ + pos_;
  pos_ += static_cast<std::size_t>(n);
  return p;
}

ByteReader ByteReader::sub(std::uint64_t n, const char* field) {
  const std::uint8_t* p = bytes(n, field);
  return ByteReader(p, static_cast<std::size_t>(n), context_ + " / " + field);
}

void ByteWriter::string(const std::string& s) {
  u32(static_cast<std::uint32_t>(s.size()));
  raw(s.data(), s.size());
}

void ByteWriter::raw(const void* data, std::size_t n) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  buf_.insert(buf_.end(), p, p + n);
}

}  // namespace fuse::io

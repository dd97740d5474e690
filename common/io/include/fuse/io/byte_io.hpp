// Little-endian byte cursor (bounds-checked reading) and byte buffer (writing) for binary
// formats. Every read checks the remaining length first and throws InputError naming the
// context (record and file offset) instead of reading past the end.
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "fuse/io/sensor_source.hpp"

namespace fuse::io {

class ByteReader {
 public:
  /// `context` names what is being read (e.g. "Chunk record at offset 58") for error messages.
  ByteReader(const std::uint8_t* data, std::size_t size, std::string context)
      : data_(data), size_(size), context_(std::move(context)) {}

  std::uint8_t u8() { return fixed<std::uint8_t>("uint8"); }
  std::uint16_t u16() { return fixed<std::uint16_t>("uint16"); }
  std::uint32_t u32() { return fixed<std::uint32_t>("uint32"); }
  std::uint64_t u64() { return fixed<std::uint64_t>("uint64"); }
  /// MCAP String: uint32 byte length + bytes.
  std::string string(const char* field);
  /// `n` raw bytes, returned as a pointer into the buffer.
  const std::uint8_t* bytes(std::uint64_t n, const char* field);
  /// A sub-reader over the next `n` bytes (e.g. a length-prefixed map), advancing past them.
  ByteReader sub(std::uint64_t n, const char* field);

  /// The unread bytes as a new reader with another context (e.g. naming a record).
  ByteReader rest(std::string context) const { return ByteReader(data_ + pos_, size_ - pos_, std::move(context)); }

  std::size_t position() const { return pos_; }
  std::size_t remaining() const { return size_ - pos_; }
  bool done() const { return pos_ == size_; }
  const std::string& context() const { return context_; }
  [[noreturn]] void fail(const std::string& what) const;

 private:
  template <typename T>
  T fixed(const char* type) {
    require(sizeof(T), type);
    T value;
    std::memcpy(&value, data_ + pos_, sizeof(T));  // the host is little-endian (checked below)
    pos_ += sizeof(T);
    return value;
  }
  void require(std::uint64_t n, const char* field) const;

  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
  std::string context_;
};

class ByteWriter {
 public:
  void u8(std::uint8_t v) { buf_.push_back(v); }
  void u16(std::uint16_t v) { raw(&v, sizeof v); }
  void u32(std::uint32_t v) { raw(&v, sizeof v); }
  void u64(std::uint64_t v) { raw(&v, sizeof v); }
  void string(const std::string& s);
  void raw(const void* data, std::size_t n);

  std::vector<std::uint8_t>& buffer() { return buf_; }
  const std::vector<std::uint8_t>& buffer() const { return buf_; }
  std::size_t size() const { return buf_.size(); }
  /// Overwrites a uint32 written earlier at `pos` (for length prefixes known afterwards).
  void patch_u32(std::size_t pos, std::uint32_t v) { std::memcpy(buf_.data() + pos, &v, sizeof v); }
  void patch_u64(std::size_t pos, std::uint64_t v) { std::memcpy(buf_.data() + pos, &v, sizeof v); }
  void clear() { buf_.clear(); }

 private:
  std::vector<std::uint8_t> buf_;
};

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "MCAP/CDR readers assume a little-endian host");

}  // namespace fuse::io

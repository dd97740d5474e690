// Bounds-checked reader of serialised ROS messages in either wire format:
//  - ROS 1 serialisation (wiki "roscpp/Overview/MessagesSerializationAndAdaptingTypes",
//    "ROS/Message_serialization"): little-endian, no padding, string = uint32 length + bytes,
//    variable array = uint32 count + elements, fixed array = elements only.
//  - ROS 2 CDR (OMG DDS-XTypes 1.3 §7.4.3, XCDR1 / plain CDR as rmw writes it): a 4-byte
//    encapsulation header (0x00 0x00 big-endian, 0x00 0x01 little-endian, 2 option bytes), then
//    primitives aligned to their size relative to the first byte after that header; string =
//    uint32 length including the terminating NUL + bytes; sequence = uint32 count + elements.
// Every read checks the remaining length and throws fuse::io::InputError naming `context`.
#pragma once

#include <cstdint>
#include <cstring>
#include <string>

#include "fuse/rosbag/bag_reader.hpp"

namespace fuse::rosbag {

class MessageReader {
 public:
  MessageReader(const std::uint8_t* data, std::size_t size, Serialization s, std::string context);

  std::uint8_t u8();
  bool boolean() { return u8() != 0; }
  std::uint16_t u16() { return fixed<std::uint16_t>(); }
  std::uint32_t u32() { return fixed<std::uint32_t>(); }
  std::int32_t i32() { return fixed<std::int32_t>(); }
  std::uint64_t u64() { return fixed<std::uint64_t>(); }
  float f32() { return fixed<float>(); }
  double f64() { return fixed<double>(); }
  std::string string();
  /// Length of a variable array whose elements take at least `min_element_bytes` each; a count
  /// the remaining bytes cannot hold is refused before anything is allocated.
  std::uint32_t sequence_length(std::size_t min_element_bytes);
  /// `n` raw bytes (uint8[] contents), as a pointer into the buffer.
  const std::uint8_t* bytes(std::size_t n);
  /// std_msgs/Header: ROS 1 (uint32 seq, time stamp, string frame_id) or ROS 2 (int32 sec,
  /// uint32 nanosec, string frame_id). Returns the stamp in ns; a negative or invalid one throws.
  std::uint64_t header(std::string* frame_id = nullptr);

  bool big_endian() const { return big_endian_; }
  bool cdr() const { return cdr_; }
  std::size_t remaining() const { return size_ - pos_; }
  const std::string& context() const { return context_; }
  [[noreturn]] void fail(const std::string& what) const;

 private:
  void align(std::size_t n);
  void need(std::size_t n) const;
  template <typename T>
  T fixed() {
    align(sizeof(T));
    need(sizeof(T));
    std::uint8_t b[sizeof(T)];
    std::memcpy(b, data_ + pos_, sizeof(T));
    if (big_endian_) {
      for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
    }
    pos_ += sizeof(T);
    T v;
    std::memcpy(&v, b, sizeof(T));
    return v;
  }

  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
  std::size_t origin_ = 0;  ///< CDR alignment origin (after the encapsulation header)
  bool cdr_;
  bool big_endian_ = false;
  std::string context_;
};

}  // namespace fuse::rosbag

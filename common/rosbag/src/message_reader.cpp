#include "fuse/rosbag/message_reader.hpp"

#include "fuse/io/sensor_source.hpp"

namespace fuse::rosbag {

MessageReader::MessageReader(const std::uint8_t* data, std::size_t size, Serialization s, std::string context)
    : data_(data), size_(size), cdr_(s == Serialization::kCdr), context_(std::move(context)) {
  if (cdr_) {
    // Encapsulation header (DDS-XTypes 1.3 §7.6.3.1.2): representation id, then options.
    need(4);
    if (data_[0] != 0 || (data_[1] != 0 && data_[1] != 1)) {
      fail("CDR encapsulation " + std::to_string(data_[0]) + "," + std::to_string(data_[1]) +
           " is not plain CDR (0,0 big-endian or 0,1 little-endian)");
    }
    big_endian_ = data_[1] == 0;
    pos_ = origin_ = 4;
  }
}

void MessageReader::fail(const std::string& what) const {
  throw io::InputError(context_ + ": " + what + " (at byte " + std::to_string(pos_) + " of " + std::to_string(size_) + ")");
}

void MessageReader::need(std::size_t n) const {
  if (n > size_ - pos_) fail("message too short: needs " + std::to_string(n) + " more bytes, " + std::to_string(size_ - pos_) + " left");
}

void MessageReader::align(std::size_t n) {
  if (!cdr_) return;
  const std::size_t rel = pos_ - origin_;
  const std::size_t pad = (n - rel % n) % n;
  need(pad);
  pos_ += pad;
}

std::uint8_t MessageReader::u8() {
  need(1);
  return data_[pos_++];
}

std::string MessageReader::string() {
  const std::uint32_t n = u32();
  need(n);
  std::size_t len = n;
  if (cdr_) {
    // CDR strings count their terminating NUL.
    if (n == 0 || data_[pos_ + n - 1] != 0) fail("CDR string without its terminating NUL");
    len = n - 1;
  }
  std::string s(reinterpret_cast<const char*>(data_ + pos_), len);
  pos_ += n;
  return s;
}

std::uint32_t MessageReader::sequence_length(std::size_t min_element_bytes) {
  const std::uint32_t n = u32();
  if (min_element_bytes > 0 && n > (size_ - pos_) / min_element_bytes) {
    fail("array of " + std::to_string(n) + " elements cannot fit in the " + std::to_string(size_ - pos_) + " bytes left");
  }
  return n;
}

const std::uint8_t* MessageReader::bytes(std::size_t n) {
  need(n);
  const std::uint8_t* p = data_ + pos_;
  pos_ += n;
  return p;
}

std::uint64_t MessageReader::header(std::string* frame_id) {
  std::uint64_t sec;
  std::uint32_t nsec;
  if (cdr_) {
    const std::int32_t s = i32();  // builtin_interfaces/Time
    nsec = u32();
    if (s < 0) fail("negative header stamp " + std::to_string(s) + " s");
    sec = static_cast<std::uint64_t>(s);
  } else {
    u32();  // seq
    sec = u32();
    nsec = u32();
  }
  if (nsec >= 1000000000u) fail("header stamp nanoseconds " + std::to_string(nsec) + " out of range");
  std::string frame = string();
  if (frame_id) *frame_id = std::move(frame);
  return sec * 1000000000ull + nsec;
}

}  // namespace fuse::rosbag

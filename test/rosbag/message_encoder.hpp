// Test-only encoder of ROS 1 serialisation and little-endian CDR, to build messages with known
// contents for the decoder tests (the independent writer of test bags is the npm interop test).
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "fuse/rosbag/bag_reader.hpp"

namespace fuse::rosbag::test {

class Encoder {
 public:
  explicit Encoder(Serialization s) : cdr_(s == Serialization::kCdr) {
    if (cdr_) buf = {0, 1, 0, 0};
  }
  template <typename T>
  void put(T v) {
    if (cdr_) while ((buf.size() - 4) % sizeof(T) != 0) buf.push_back(0);
    const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
    buf.insert(buf.end(), p, p + sizeof(T));
  }
  void str(const std::string& s) {
    put<std::uint32_t>(static_cast<std::uint32_t>(s.size() + (cdr_ ? 1 : 0)));
    buf.insert(buf.end(), s.begin(), s.end());
    if (cdr_) buf.push_back(0);
  }
  void header(std::uint64_t stamp_ns, const std::string& frame) {
    if (!cdr_) put<std::uint32_t>(7);  // seq
    if (cdr_) put<std::int32_t>(static_cast<std::int32_t>(stamp_ns / 1000000000ull));
    else put<std::uint32_t>(static_cast<std::uint32_t>(stamp_ns / 1000000000ull));
    put<std::uint32_t>(static_cast<std::uint32_t>(stamp_ns % 1000000000ull));
    str(frame);
  }
  std::vector<std::uint8_t> buf;

 private:
  bool cdr_;
};

}  // namespace fuse::rosbag::test

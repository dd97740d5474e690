// Builds classic pcap files in memory for the tests, from the format's description
// (draft-ietf-opsawg-pcap): either byte order, µs or ns timestamps, Ethernet / Linux SLL /
// SLL2 / raw IP link layers, IPv4 + UDP datagrams split into fragments on request.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace fuse::test::pcap {

struct Options {
  bool swapped = false;      ///< write in the other byte order
  bool nanosecond = false;   ///< 0xA1B23C4D magic
  std::uint32_t link_type = 1;
  std::uint32_t snaplen = 262144;
};

class Writer {
 public:
  explicit Writer(Options o) : o_(o) {
    u32(o.nanosecond ? 0xA1B23C4D : 0xA1B2C3D4);
    u16(2);
    u16(4);
    u32(0);
    u32(0);
    u32(o.snaplen);
    u32(o.link_type);
  }

  /// One record holding `frame` (link layer included); `orig` > frame size marks a cut record.
  void record(double t, const std::vector<std::uint8_t>& frame, std::uint32_t orig = 0) {
    const auto sec = static_cast<std::uint32_t>(t);
    const double frac = t - sec;
    u32(sec);
    u32(static_cast<std::uint32_t>(frac * (o_.nanosecond ? 1e9 : 1e6) + 0.5));
    u32(static_cast<std::uint32_t>(frame.size()));
    u32(orig ? orig : static_cast<std::uint32_t>(frame.size()));
    bytes_.insert(bytes_.end(), frame.begin(), frame.end());
  }

  /// A UDP datagram as one record, or as IPv4 fragments of at most `mtu` bytes of IP payload
  /// (multiple of 8), each its own record; `reverse` writes the fragments last-first.
  void udp(double t, std::uint16_t src_port, std::uint16_t dst_port, const std::vector<std::uint8_t>& payload,
           std::size_t mtu = 0, bool reverse = false, std::uint16_t ip_id = 1) {
    std::vector<std::uint8_t> udp_bytes;
    be16(udp_bytes, src_port);
    be16(udp_bytes, dst_port);
    be16(udp_bytes, static_cast<std::uint16_t>(payload.size() + 8));
    be16(udp_bytes, 0);
    udp_bytes.insert(udp_bytes.end(), payload.begin(), payload.end());
    std::vector<std::vector<std::uint8_t>> frames;
    if (mtu == 0 || udp_bytes.size() <= mtu) {
      frames.push_back(frame(ip(udp_bytes, 0, udp_bytes.size(), false, ip_id)));
    } else {
      for (std::size_t off = 0; off < udp_bytes.size(); off += mtu) {
        const std::size_t n = std::min(mtu, udp_bytes.size() - off);
        frames.push_back(frame(ip(udp_bytes, off, n, off + n < udp_bytes.size(), ip_id)));
      }
    }
    if (reverse) std::reverse(frames.begin(), frames.end());
    for (const auto& f : frames) record(t, f);
  }

  /// A non-IPv4 frame (an ARP request's EtherType) for the skip counters.
  void arp(double t) {
    std::vector<std::uint8_t> f;
    switch (o_.link_type) {
      case 1:
        f.assign(12, 0);
        be16(f, 0x0806);
        break;
      case 113:
        f.assign(14, 0);
        be16(f, 0x0806);
        break;
      case 276:
        be16(f, 0x0806);
        f.resize(20, 0);
        break;
      default:  // raw IP: an IPv6 header instead
        f.assign(40, 0);
        f[0] = 0x60;
        break;
    }
    f.resize(f.size() + 28, 0);
    record(t, f);
  }

  const std::vector<std::uint8_t>& bytes() const { return bytes_; }

 private:
  static void be16(std::vector<std::uint8_t>& v, std::uint16_t x) {
    v.push_back(static_cast<std::uint8_t>(x >> 8));
    v.push_back(static_cast<std::uint8_t>(x));
  }
  std::vector<std::uint8_t> ip(const std::vector<std::uint8_t>& body, std::size_t off, std::size_t n, bool more,
                               std::uint16_t id) const {
    std::vector<std::uint8_t> v;
    v.push_back(0x45);
    v.push_back(0);
    be16(v, static_cast<std::uint16_t>(20 + n));
    be16(v, id);
    be16(v, static_cast<std::uint16_t>((more ? 0x2000 : 0) | (off / 8)));
    v.push_back(64);
    v.push_back(17);
    be16(v, 0);
    for (std::uint8_t b : {192, 168, 1, 10, 192, 168, 1, 1}) v.push_back(b);
    v.insert(v.end(), body.begin() + static_cast<std::ptrdiff_t>(off), body.begin() + static_cast<std::ptrdiff_t>(off + n));
    return v;
  }
  std::vector<std::uint8_t> frame(const std::vector<std::uint8_t>& ip_bytes) const {
    std::vector<std::uint8_t> f;
    switch (o_.link_type) {
      case 1:
        f.assign(12, 0xAA);
        be16(f, 0x0800);
        break;
      case 113:
        f.assign(14, 0);
        be16(f, 0x0800);
        break;
      case 276:
        be16(f, 0x0800);
        f.resize(20, 0);
        break;
      default:
        break;  // raw IP
    }
    f.insert(f.end(), ip_bytes.begin(), ip_bytes.end());
    return f;
  }
  void u16(std::uint16_t v) {
    if (o_.swapped) v = __builtin_bswap16(v);
    raw(&v, 2);
  }
  void u32(std::uint32_t v) {
    if (o_.swapped) v = __builtin_bswap32(v);
    raw(&v, 4);
  }
  void raw(const void* p, std::size_t n) {
    const auto* b = static_cast<const std::uint8_t*>(p);
    bytes_.insert(bytes_.end(), b, b + n);
  }

  Options o_;
  std::vector<std::uint8_t> bytes_;
};

}  // namespace fuse::test::pcap

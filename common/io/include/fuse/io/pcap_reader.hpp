// UDP datagrams from a classic libpcap capture file (the "pcap" format of libpcap / tcpdump,
// as described in draft-ietf-opsawg-pcap):
//
//   file header (24 bytes): magic 0xA1B2C3D4 (µs timestamps) or 0xA1B23C4D (ns timestamps),
//     written in the capturing host's byte order (so read as 0xD4C3B2A1 / 0x4D3CB2A1 when that
//     order differs from ours), version 2.4, thiszone, sigfigs, snaplen, link type
//   record header (16 bytes): ts_sec, ts_usec|ts_nsec, incl_len (bytes stored), orig_len
//
// Link types: 1 (Ethernet II, with 802.1Q VLAN tags), 113 (Linux cooked capture SLL),
// 276 (SLL2) and 101 (raw IP). Above the link layer only IPv4 (RFC 791) carrying UDP (RFC 768)
// is read; fragmented datagrams are reassembled (RFC 791 §3.2 / RFC 815) from their fragments
// by (source, destination, protocol, identification). Everything else (ARP, IPv6, TCP,
// fragments that never complete, datagrams cut by the snapshot length) is skipped and counted
// by reason; a file that is not a pcap or ends inside a record raises InputError.
#pragma once

#include <cstdint>
#include <fstream>
#include <istream>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "fuse/io/sensor_source.hpp"

namespace fuse::io::pcap {

inline constexpr std::uint32_t kLinkEthernet = 1;
inline constexpr std::uint32_t kLinkRawIp = 101;
inline constexpr std::uint32_t kLinkLinuxSll = 113;
inline constexpr std::uint32_t kLinkLinuxSll2 = 276;

/// Skip reasons (keys of PcapReader::skipped()).
namespace skip {
inline constexpr const char* kNotIpv4 = "pcap_not_ipv4";                  ///< ARP, IPv6, LLDP, ...
inline constexpr const char* kNotUdp = "pcap_not_udp";                    ///< TCP, ICMP, ...
inline constexpr const char* kCutBySnaplen = "pcap_cut_by_snaplen";       ///< incl_len < orig_len
inline constexpr const char* kMalformedFrame = "pcap_malformed_frame";    ///< headers inconsistent
inline constexpr const char* kIncompleteFragments = "pcap_incomplete_ip_fragments";  ///< never completed
}  // namespace skip

/// One UDP datagram (reassembled when it came in fragments).
struct UdpDatagram {
  double capture_time = 0.0;  ///< s, capture clock of the record that completed the datagram
  std::uint32_t src_ip = 0, dst_ip = 0;  ///< host byte order
  std::uint16_t src_port = 0, dst_port = 0;
  std::vector<std::uint8_t> payload;
};

struct PcapConfig {
  /// Fragments of a datagram older than this (capture time) are given up when newer records come.
  double fragment_timeout_s = 2.0;
  /// At most this many datagrams in reassembly at once; the oldest is given up beyond it.
  std::size_t max_pending_datagrams = 64;
  /// Largest reassembled IPv4 datagram (the protocol's own limit).
  std::size_t max_datagram_bytes = 65535;
};

class PcapReader {
 public:
  /// Opens `path` and reads its file header; throws InputError (not a pcap, unknown link type).
  explicit PcapReader(const std::string& path, PcapConfig config = {});
  /// Reads from a stream (e.g. bytes in memory); `name` names it in messages.
  PcapReader(std::unique_ptr<std::istream> in, std::string name, PcapConfig config = {});

  /// Next UDP datagram; false at the end of the file. Throws InputError when the file ends
  /// inside a record or a record header is impossible (incl_len beyond the snapshot length).
  bool next(UdpDatagram& out);

  std::uint32_t link_type() const { return link_type_; }
  bool nanosecond() const { return nanosecond_; }
  bool swapped() const { return swapped_; }
  std::uint64_t records() const { return records_; }
  /// Records or datagrams skipped, by reason (pcap::skip::*).
  const std::map<std::string, std::uint64_t>& skipped() const { return skipped_; }
  const std::string& name() const { return name_; }

 private:
  struct Fragments {
    double first_seen = 0.0;
    std::vector<std::uint8_t> data;
    std::vector<std::pair<std::size_t, std::size_t>> have;  ///< [begin, end) byte ranges received
    std::size_t total = 0;  ///< known once the last fragment (MF = 0) arrived; 0 before
  };

  void read_header();
  bool read_exact(void* dst, std::size_t n);  ///< false at a clean end (0 bytes read)
  std::uint32_t order32(std::uint32_t v) const;
  std::uint16_t order16(std::uint16_t v) const;
  /// Decodes one record's link layer and IP; true when `out` holds a complete UDP datagram.
  bool handle_record(const std::uint8_t* frame, std::size_t size, double t, UdpDatagram& out);
  bool handle_ipv4(const std::uint8_t* ip, std::size_t size, double t, UdpDatagram& out);
  bool udp(const std::uint8_t* data, std::size_t size, std::uint32_t src, std::uint32_t dst, double t,
           UdpDatagram& out);
  void expire_fragments(double now);

  PcapConfig config_;
  std::unique_ptr<std::istream> in_;
  std::string name_;
  bool swapped_ = false, nanosecond_ = false;
  std::uint32_t snaplen_ = 0, link_type_ = 0;
  std::uint64_t records_ = 0, offset_ = 0;
  std::vector<std::uint8_t> record_;
  std::map<std::string, std::uint64_t> skipped_;
  using FragmentKey = std::tuple<std::uint32_t, std::uint32_t, std::uint16_t, std::uint8_t>;  ///< src, dst, id, protocol
  std::map<FragmentKey, Fragments> pending_;
};

}  // namespace fuse::io::pcap

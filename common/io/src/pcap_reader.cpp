#include "fuse/io/pcap_reader.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>

namespace fuse::io::pcap {

namespace {

// File header magic numbers (draft-ietf-opsawg-pcap §4).
constexpr std::uint32_t kMagicMicro = 0xA1B2C3D4;
constexpr std::uint32_t kMagicNano = 0xA1B23C4D;
constexpr std::size_t kFileHeaderSize = 24;
constexpr std::size_t kRecordHeaderSize = 16;
/// Largest record we accept when the file's snapshot length is 0 or absurd (libpcap's own bound).
constexpr std::uint32_t kMaxRecord = 262144;

// EtherTypes (IEEE 802.3) and IPv4 protocol numbers (IANA).
constexpr std::uint16_t kEtherIpv4 = 0x0800;
constexpr std::uint16_t kEtherVlan = 0x8100;
constexpr std::uint16_t kEtherQinQ = 0x88A8;
constexpr std::uint8_t kProtoUdp = 17;

std::uint16_t be16(const std::uint8_t* p) { return static_cast<std::uint16_t>((p[0] << 8) | p[1]); }
std::uint32_t be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | p[3];
}

}  // namespace

PcapReader::PcapReader(const std::string& path, PcapConfig config)
    : config_(config), name_(path) {
  auto f = std::make_unique<std::ifstream>(path, std::ios::binary);
  if (!*f) throw InputError("pcap " + path + ": cannot open the file");
  in_ = std::move(f);
  read_header();
}

PcapReader::PcapReader(std::unique_ptr<std::istream> in, std::string name, PcapConfig config)
    : config_(config), in_(std::move(in)), name_(std::move(name)) {
  read_header();
}

bool PcapReader::read_exact(void* dst, std::size_t n) {
  in_->read(static_cast<char*>(dst), static_cast<std::streamsize>(n));
  const auto got = static_cast<std::size_t>(in_->gcount());
  if (got == n) {
    offset_ += n;
    return true;
  }
  if (got == 0 && in_->eof()) return false;
  throw InputError("pcap " + name_ + ": truncated: the file ends " + std::to_string(got) + " bytes into a " +
                   std::to_string(n) + "-byte read at offset " + std::to_string(offset_) + " (record " +
                   std::to_string(records_ + 1) + ")");
}

std::uint32_t PcapReader::order32(std::uint32_t v) const { return swapped_ ? __builtin_bswap32(v) : v; }
std::uint16_t PcapReader::order16(std::uint16_t v) const { return swapped_ ? __builtin_bswap16(v) : v; }

void PcapReader::read_header() {
  std::uint8_t h[kFileHeaderSize];
  if (!read_exact(h, sizeof h)) throw InputError("pcap " + name_ + ": empty file (no pcap file header)");
  std::uint32_t magic;
  std::memcpy(&magic, h, 4);
  if (magic == kMagicMicro || magic == kMagicNano) {
    swapped_ = false;
  } else if (__builtin_bswap32(magic) == kMagicMicro || __builtin_bswap32(magic) == kMagicNano) {
    swapped_ = true;
    magic = __builtin_bswap32(magic);
  } else {
    char hex[16];
    std::snprintf(hex, sizeof hex, "0x%08X", magic);
    throw InputError("pcap " + name_ + ": not a pcap file (magic " + std::string(hex) +
                     "; pcapng and other formats are not read)");
  }
  nanosecond_ = magic == kMagicNano;
  std::uint16_t major, minor;
  std::memcpy(&major, h + 4, 2);
  std::memcpy(&minor, h + 6, 2);
  major = order16(major);
  minor = order16(minor);
  if (major != 2) {
    throw InputError("pcap " + name_ + ": unsupported version " + std::to_string(major) + "." + std::to_string(minor) +
                     " (expected 2.x)");
  }
  std::memcpy(&snaplen_, h + 16, 4);
  std::memcpy(&link_type_, h + 20, 4);
  snaplen_ = order32(snaplen_);
  // The link type's upper bits hold the FCS length flags (draft §4, LinkType and additional info).
  link_type_ = order32(link_type_) & 0x0FFFFFFF;
  if (link_type_ != kLinkEthernet && link_type_ != kLinkLinuxSll && link_type_ != kLinkLinuxSll2 &&
      link_type_ != kLinkRawIp) {
    throw InputError("pcap " + name_ + ": unsupported link type " + std::to_string(link_type_) +
                     " (read: 1 Ethernet, 101 raw IP, 113 Linux SLL, 276 Linux SLL2)");
  }
}

bool PcapReader::next(UdpDatagram& out) {
  for (;;) {
    std::uint8_t h[kRecordHeaderSize];
    if (!read_exact(h, sizeof h)) {
      // Datagrams still in reassembly at the end of the capture never completed.
      if (!pending_.empty()) skipped_[skip::kIncompleteFragments] += pending_.size();
      pending_.clear();
      return false;
    }
    std::uint32_t fields[4];
    std::memcpy(fields, h, sizeof fields);
    for (auto& f : fields) f = order32(f);
    const std::uint32_t incl = fields[2], orig = fields[3];
    const std::uint32_t limit = std::max(snaplen_ == 0 || snaplen_ > kMaxRecord ? kMaxRecord : snaplen_, 65535u);
    if (incl > limit) {
      throw InputError("pcap " + name_ + ": record " + std::to_string(records_ + 1) + " at offset " +
                       std::to_string(offset_ - kRecordHeaderSize) + " claims " + std::to_string(incl) +
                       " bytes, more than the snapshot length " + std::to_string(limit) + " (corrupt file)");
    }
    const std::uint32_t frac_unit = nanosecond_ ? 1000000000u : 1000000u;
    if (fields[1] >= frac_unit) {
      throw InputError("pcap " + name_ + ": record " + std::to_string(records_ + 1) + " has a sub-second timestamp " +
                       std::to_string(fields[1]) + " out of range (corrupt file)");
    }
    record_.resize(incl);
    if (incl > 0 && !read_exact(record_.data(), incl)) {
      throw InputError("pcap " + name_ + ": truncated: the file ends inside record " + std::to_string(records_ + 1) +
                       " (header says " + std::to_string(incl) + " bytes)");
    }
    ++records_;
    const double t = static_cast<double>(fields[0]) + static_cast<double>(fields[1]) / frac_unit;
    if (incl < orig) {
      ++skipped_[skip::kCutBySnaplen];
      continue;
    }
    expire_fragments(t);
    if (handle_record(record_.data(), record_.size(), t, out)) return true;
  }
}

bool PcapReader::handle_record(const std::uint8_t* frame, std::size_t size, double t, UdpDatagram& out) {
  std::size_t off = 0;
  std::uint16_t ether_type = 0;
  switch (link_type_) {
    case kLinkEthernet:  // destination MAC, source MAC, EtherType, optional 802.1Q / 802.1ad tags
      if (size < 14) {
        ++skipped_[skip::kMalformedFrame];
        return false;
      }
      ether_type = be16(frame + 12);
      off = 14;
      while ((ether_type == kEtherVlan || ether_type == kEtherQinQ) && size >= off + 4) {
        ether_type = be16(frame + off + 2);
        off += 4;
      }
      break;
    case kLinkLinuxSll:  // packet type, ARPHRD, address length, 8-byte address, protocol
      if (size < 16) {
        ++skipped_[skip::kMalformedFrame];
        return false;
      }
      ether_type = be16(frame + 14);
      off = 16;
      break;
    case kLinkLinuxSll2:  // protocol, reserved, interface index, ARPHRD, packet type, addr len, addr
      if (size < 20) {
        ++skipped_[skip::kMalformedFrame];
        return false;
      }
      ether_type = be16(frame);
      off = 20;
      break;
    default:  // raw IP: the version nibble says which
      if (size < 1 || (frame[0] >> 4) != 4) {
        ++skipped_[skip::kNotIpv4];
        return false;
      }
      ether_type = kEtherIpv4;
  }
  if (ether_type != kEtherIpv4) {
    ++skipped_[skip::kNotIpv4];
    return false;
  }
  return handle_ipv4(frame + off, size - off, t, out);
}

// IPv4 header (RFC 791 §3.1): version/IHL, TOS, total length, identification, flags/fragment
// offset (MF = 0x2000, offset in 8-byte units), TTL, protocol, checksum, source, destination.
bool PcapReader::handle_ipv4(const std::uint8_t* ip, std::size_t size, double t, UdpDatagram& out) {
  if (size < 20 || (ip[0] >> 4) != 4) {
    ++skipped_[size < 20 ? skip::kMalformedFrame : skip::kNotIpv4];
    return false;
  }
  const std::size_t ihl = static_cast<std::size_t>(ip[0] & 0x0F) * 4;
  const std::size_t total = be16(ip + 2);
  // Ethernet pads short frames: the IP total length, not the frame, bounds the datagram.
  if (ihl < 20 || total < ihl || total > size) {
    ++skipped_[skip::kMalformedFrame];
    return false;
  }
  const std::uint16_t id = be16(ip + 4);
  const std::uint16_t flags_offset = be16(ip + 6);
  const bool more = (flags_offset & 0x2000) != 0;
  const std::size_t frag_off = static_cast<std::size_t>(flags_offset & 0x1FFF) * 8;
  const std::uint8_t proto = ip[9];
  const std::uint32_t src = be32(ip + 12), dst = be32(ip + 16);
  if (proto != kProtoUdp) {
    ++skipped_[skip::kNotUdp];
    return false;
  }
  const std::uint8_t* body = ip + ihl;
  const std::size_t body_size = total - ihl;
  if (!more && frag_off == 0) return udp(body, body_size, src, dst, t, out);

  // A fragment: collect until the byte ranges cover [0, total) of the original payload.
  const FragmentKey key{src, dst, id, proto};
  auto it = pending_.find(key);
  if (it != pending_.end() && frag_off == 0 && !it->second.have.empty() &&
      std::any_of(it->second.have.begin(), it->second.have.end(), [](const auto& r) { return r.first == 0; })) {
    // A second first fragment with the same identification: the earlier datagram never
    // completed (its other fragments were lost); give it up and start the new one.
    ++skipped_[skip::kIncompleteFragments];
    pending_.erase(it);
    it = pending_.end();
  }
  if (it == pending_.end()) {
    if (pending_.size() >= config_.max_pending_datagrams) {
      auto oldest = std::min_element(pending_.begin(), pending_.end(), [](const auto& a, const auto& b) {
        return a.second.first_seen < b.second.first_seen;
      });
      pending_.erase(oldest);
      ++skipped_[skip::kIncompleteFragments];
    }
    it = pending_.emplace(key, Fragments{}).first;
    it->second.first_seen = t;
  }
  Fragments& f = it->second;
  const std::size_t end = frag_off + body_size;
  if (end > config_.max_datagram_bytes || (more && body_size % 8 != 0) || (f.total != 0 && end > f.total) ||
      (!more && f.total != 0 && end != f.total)) {
    ++skipped_[skip::kMalformedFrame];
    ++skipped_[skip::kIncompleteFragments];
    pending_.erase(it);
    return false;
  }
  if (!more) {
    f.total = end;
    for (const auto& r : f.have) {
      if (r.second > end) {  // a fragment beyond the end the last one declares
        ++skipped_[skip::kMalformedFrame];
        ++skipped_[skip::kIncompleteFragments];
        pending_.erase(it);
        return false;
      }
    }
  }
  if (f.data.size() < end) f.data.resize(end);
  if (body_size > 0) std::memcpy(f.data.data() + frag_off, body, body_size);  // an empty fragment adds nothing
  f.have.emplace_back(frag_off, end);
  if (f.total == 0) return false;
  // Covered? Sort the ranges and walk them from 0.
  std::sort(f.have.begin(), f.have.end());
  std::size_t covered = 0;
  for (const auto& r : f.have) {
    if (r.first > covered) return false;
    covered = std::max(covered, r.second);
  }
  if (covered < f.total) return false;
  std::vector<std::uint8_t> whole = std::move(f.data);
  whole.resize(f.total);
  pending_.erase(it);
  return udp(whole.data(), whole.size(), src, dst, t, out);
}

// UDP header (RFC 768): source port, destination port, length (header + data), checksum.
bool PcapReader::udp(const std::uint8_t* data, std::size_t size, std::uint32_t src, std::uint32_t dst, double t,
                     UdpDatagram& out) {
  if (size < 8) {
    ++skipped_[skip::kMalformedFrame];
    return false;
  }
  const std::size_t length = be16(data + 4);
  if (length < 8 || length > size) {
    ++skipped_[skip::kMalformedFrame];
    return false;
  }
  out.capture_time = t;
  out.src_ip = src;
  out.dst_ip = dst;
  out.src_port = be16(data);
  out.dst_port = be16(data + 2);
  out.payload.assign(data + 8, data + length);
  return true;
}

void PcapReader::expire_fragments(double now) {
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (now - it->second.first_seen > config_.fragment_timeout_s) {
      ++skipped_[skip::kIncompleteFragments];
      it = pending_.erase(it);
    } else {
      ++it;
    }
  }
}

}  // namespace fuse::io::pcap

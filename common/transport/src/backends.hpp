// The two backends behind make_participant(), plus what they share: reading the key of a
// keyed sample (a uint64 first member) and the key hash the DDS specification defines for it.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "fuse/transport/transport.hpp"

namespace fuse::transport::detail {

std::unique_ptr<Participant> make_fastdds_participant(const TransportConfig& config, const std::string& name);
std::unique_ptr<Participant> make_cyclonedds_participant(const TransportConfig& config, const std::string& name);

/// The unicast discovery peers of both backends: 127.0.0.1 unless DDS is bound to named
/// interfaces, then the configured peers and this computer's own interfaces (its other
/// processes), so one peer list serves every computer of a system.
inline std::vector<std::string> discovery_peers(const TransportConfig& config) {
  std::vector<std::string> peers = config.peers;
  if (config.interfaces.empty()) peers.emplace_back("127.0.0.1");
  peers.insert(peers.end(), config.interfaces.begin(), config.interfaces.end());
  return peers;
}

/// XCDR key hash of a type whose only key is its first member, a uint64: the key serialised
/// big-endian (8 bytes) and zero-padded to 16. The key is read from the sample honouring the
/// encapsulation's endianness (identifier bit 0: 1 = little endian). False when the sample is
/// too short to hold a key (the hash is then all zero).
inline bool key_hash_from_sample(const std::uint8_t* data, std::size_t size, std::array<std::uint8_t, 16>& hash) {
  hash.fill(0);
  if (data == nullptr || size < 4 + 8) return false;
  const bool little = (data[1] & 1u) != 0;
  for (int i = 0; i < 8; ++i) hash[i] = little ? data[4 + 7 - i] : data[4 + i];
  return true;
}

/// Size of a received sample without the padding its encapsulation options declare (XTypes:
/// the low two bits of the options are the number of padding bytes at the end).
inline std::size_t unpadded_size(const std::uint8_t* data, std::size_t size) {
  if (size < 4) return size;
  const std::size_t padding = data[3] & 3u;
  return size >= 4 + padding ? size - padding : size;
}

}  // namespace fuse::transport::detail

// libFuzzer target for the pcap reader (issue 5): any byte string is read as a capture file;
// it must give UDP datagrams within the protocol's bounds or InputError (a clear message),
// never a crash, an out-of-bounds read or unbounded memory (ASan/UBSan).
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <sstream>
#include <string>

#include "fuse/io/pcap_reader.hpp"

namespace {
void require(bool ok) {
  if (!ok) std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace fuse::io;
  try {
    pcap::PcapConfig config;
    config.max_pending_datagrams = 4;
    pcap::PcapReader reader(std::make_unique<std::istringstream>(std::string(reinterpret_cast<const char*>(data), size)),
                            "fuzz.pcap", config);
    pcap::UdpDatagram d;
    std::uint64_t n = 0;
    while (reader.next(d)) {
      require(d.payload.size() <= 65535 - 8);
      require(++n <= size);  // every datagram consumed at least one input byte
    }
  } catch (const InputError& e) {
    require(e.what()[0] != '\0');
  }
  return 0;
}

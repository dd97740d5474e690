// pcap reader: every variant of the file format (byte order x timestamp resolution x link type)
// on files built from the format's description, IPv4 fragment reassembly (in order, reversed,
// lost fragments, a reused identification), bad files, and the real Ouster captures.
#include <gtest/gtest.h>

#include <sstream>

#include "fuse/io/pcap_reader.hpp"
#include "pcap_test_packets.hpp"
#include "test_util.hpp"

namespace fuse::io {
namespace {

namespace tp = fuse::test::pcap;

std::vector<std::uint8_t> pattern(std::size_t n, std::uint8_t seed) {
  std::vector<std::uint8_t> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<std::uint8_t>(seed + i * 7);
  return v;
}

pcap::PcapReader open(const std::vector<std::uint8_t>& bytes, pcap::PcapConfig config = {}) {
  return pcap::PcapReader(
      std::make_unique<std::istringstream>(std::string(bytes.begin(), bytes.end())), "test.pcap", config);
}

struct Variant {
  bool swapped;
  bool nanosecond;
  std::uint32_t link_type;
};

class PcapVariants : public ::testing::TestWithParam<Variant> {};

TEST_P(PcapVariants, ReadsUdpDatagramsWithPortsTimesAndFragments) {
  const Variant v = GetParam();
  tp::Writer w({v.swapped, v.nanosecond, v.link_type});
  const auto small = pattern(48, 1), big = pattern(8448, 3), big2 = pattern(3001, 5);
  w.udp(1000.25, 5000, 7503, small);
  w.arp(1000.26);
  w.udp(1000.5, 5001, 7502, big, 1480, false, 10);      // 6 fragments, in order
  w.udp(1000.75, 5002, 7502, big2, 1480, true, 11);     // 3 fragments, last first
  pcap::PcapReader r = open(w.bytes());
  EXPECT_EQ(r.swapped(), v.swapped);
  EXPECT_EQ(r.nanosecond(), v.nanosecond);
  EXPECT_EQ(r.link_type(), v.link_type);
  pcap::UdpDatagram d;
  ASSERT_TRUE(r.next(d));
  EXPECT_NEAR(d.capture_time, 1000.25, 1e-6);
  EXPECT_EQ(d.src_port, 5000);
  EXPECT_EQ(d.dst_port, 7503);
  EXPECT_EQ(d.src_ip, 0xC0A8010Au);
  EXPECT_EQ(d.dst_ip, 0xC0A80101u);
  EXPECT_EQ(d.payload, small);
  ASSERT_TRUE(r.next(d));
  EXPECT_EQ(d.dst_port, 7502);
  EXPECT_EQ(d.payload, big);
  EXPECT_NEAR(d.capture_time, 1000.5, 1e-6);
  ASSERT_TRUE(r.next(d));
  EXPECT_EQ(d.src_port, 5002);
  EXPECT_EQ(d.payload, big2);
  EXPECT_FALSE(r.next(d));
  EXPECT_EQ(r.records(), 1u + 1u + 6u + 3u);
  EXPECT_EQ(r.skipped().at(pcap::skip::kNotIpv4), 1u);
}

INSTANTIATE_TEST_SUITE_P(
    Formats, PcapVariants,
    ::testing::Values(Variant{false, false, 1}, Variant{true, false, 1}, Variant{false, true, 1},
                      Variant{true, true, 1}, Variant{false, false, 113}, Variant{true, true, 113},
                      Variant{false, false, 276}, Variant{false, true, 101}),
    [](const auto& info) {
      return std::string(info.param.swapped ? "swapped" : "native") + (info.param.nanosecond ? "_ns" : "_us") +
             "_link" + std::to_string(info.param.link_type);
    });

TEST(PcapReader, LostFragmentsAreCountedAndAReusedIdStartsAFreshDatagram) {
  tp::Writer w({});
  const auto a = pattern(4000, 9), b = pattern(4000, 17);
  // Datagram a loses its middle fragment; datagram b reuses a's IP identification.
  tp::Writer frag({});
  w.udp(1.0, 1, 7502, a, 1480, false, 42);
  std::vector<std::uint8_t> bytes = w.bytes();
  // Drop the second record (a's middle fragment): header 24, records of 16 + frame bytes.
  const std::size_t first = 24 + 16 + 14 + 20 + 1480;
  const std::size_t second = 16 + 14 + 20 + 1480;
  bytes.erase(bytes.begin() + static_cast<std::ptrdiff_t>(first), bytes.begin() + static_cast<std::ptrdiff_t>(first + second));
  tp::Writer w2({});
  w2.udp(1.5, 1, 7502, b, 1480, false, 42);
  bytes.insert(bytes.end(), w2.bytes().begin() + 24, w2.bytes().end());
  pcap::PcapReader r = open(bytes);
  pcap::UdpDatagram d;
  ASSERT_TRUE(r.next(d));
  EXPECT_EQ(d.payload, b);
  EXPECT_FALSE(r.next(d));
  EXPECT_EQ(r.skipped().at(pcap::skip::kIncompleteFragments), 1u);
}

TEST(PcapReader, FragmentsThatNeverCompleteAreCountedAtTheEndAndOnTimeout) {
  tp::Writer w({});
  w.udp(1.0, 1, 7502, pattern(4000, 1), 1480, false, 1);
  std::vector<std::uint8_t> bytes = w.bytes();
  bytes.resize(bytes.size() - (16 + 14 + 20 + (4008 - 2 * 1480)));  // without the last fragment
  tp::Writer later({});
  later.udp(10.0, 1, 7503, pattern(10, 1));  // 9 s later: the first datagram has timed out
  bytes.insert(bytes.end(), later.bytes().begin() + 24, later.bytes().end());
  pcap::PcapReader r = open(bytes);
  pcap::UdpDatagram d;
  ASSERT_TRUE(r.next(d));
  EXPECT_EQ(d.dst_port, 7503);
  EXPECT_EQ(r.skipped().at(pcap::skip::kIncompleteFragments), 1u);
  EXPECT_FALSE(r.next(d));
}

TEST(PcapReader, RecordsCutBySnaplenAreCounted) {
  tp::Writer w({});
  std::vector<std::uint8_t> frame(60, 0);
  w.record(1.0, frame, 1514);
  w.udp(2.0, 1, 2, pattern(8, 0));
  pcap::PcapReader r = open(w.bytes());
  pcap::UdpDatagram d;
  ASSERT_TRUE(r.next(d));
  EXPECT_EQ(r.skipped().at(pcap::skip::kCutBySnaplen), 1u);
}

TEST(PcapReader, EmptyFragmentsAreHarmless) {
  // Found by fuzzing: an IPv4 fragment with no payload (total length = header) at offset 0.
  tp::Writer w({});
  std::vector<std::uint8_t> frame(12, 0);
  frame.push_back(0x08);
  frame.push_back(0x00);
  const std::uint8_t ip[20] = {0x45, 0, 0, 20, 0, 9, 0x20, 0, 64, 17, 0, 0, 10, 0, 0, 2, 10, 0, 0, 1};
  frame.insert(frame.end(), ip, ip + 20);
  w.record(1.0, frame);
  w.udp(1.1, 1, 2, pattern(8, 0));
  pcap::PcapReader r = open(w.bytes());
  pcap::UdpDatagram d;
  ASSERT_TRUE(r.next(d));
  EXPECT_EQ(d.payload, pattern(8, 0));
  EXPECT_FALSE(r.next(d));
  EXPECT_EQ(r.skipped().at(pcap::skip::kIncompleteFragments), 1u);
}

struct BadFile {
  const char* name;
  std::vector<std::uint8_t> (*make)();
  const char* message;
};

std::vector<std::uint8_t> truncated_record() {
  tp::Writer w({});
  w.udp(1.0, 1, 2, pattern(100, 0));
  auto b = w.bytes();
  b.resize(b.size() - 30);
  return b;
}
std::vector<std::uint8_t> truncated_record_header() {
  tp::Writer w({});
  w.udp(1.0, 1, 2, pattern(100, 0));
  auto b = w.bytes();
  b.resize(24 + 7);
  return b;
}
std::vector<std::uint8_t> short_file_header() { return {0xD4, 0xC3, 0xB2, 0xA1, 2, 0}; }
std::vector<std::uint8_t> empty_file() { return {}; }
std::vector<std::uint8_t> pcapng() {
  std::vector<std::uint8_t> b(28, 0);
  b[0] = 0x0A;
  b[1] = 0x0D;
  b[2] = 0x0D;
  b[3] = 0x0A;
  return b;
}
std::vector<std::uint8_t> unknown_link() { return tp::Writer({false, false, 105}).bytes(); }
std::vector<std::uint8_t> huge_record() {
  tp::Writer w({false, false, 1, 1000});
  auto b = w.bytes();
  const std::uint32_t h[4] = {1, 0, 5000000, 5000000};
  b.insert(b.end(), reinterpret_cast<const std::uint8_t*>(h), reinterpret_cast<const std::uint8_t*>(h) + 16);
  return b;
}
std::vector<std::uint8_t> bad_version() {
  auto b = tp::Writer({}).bytes();
  b[4] = 9;
  return b;
}

class PcapBadFiles : public ::testing::TestWithParam<BadFile> {};

TEST_P(PcapBadFiles, GiveAClearError) {
  const BadFile& f = GetParam();
  try {
    pcap::PcapReader r = open(f.make());
    pcap::UdpDatagram d;
    while (r.next(d)) {
    }
    FAIL() << "no error for " << f.name;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(f.message), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("test.pcap"), std::string::npos) << "names the file: " << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(
    Files, PcapBadFiles,
    ::testing::Values(BadFile{"truncated_record", truncated_record, "truncated"},
                      BadFile{"truncated_record_header", truncated_record_header, "truncated"},
                      BadFile{"short_file_header", short_file_header, "truncated"},
                      BadFile{"empty_file", empty_file, "empty file"}, BadFile{"pcapng", pcapng, "not a pcap file"},
                      BadFile{"unknown_link", unknown_link, "unsupported link type 105"},
                      BadFile{"huge_record", huge_record, "more than the snapshot length"},
                      BadFile{"bad_version", bad_version, "unsupported version 9"}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(PcapReader, MissingFileIsAClearError) {
  try {
    pcap::PcapReader r("/nonexistent/capture.pcap");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos);
  }
}

// Real captures (ouster-sdk test data): datagrams per destination port and payload size, as
// counted independently from the files' bytes; fragmented captures reassemble.
struct RealCapture {
  const char* file;
  std::map<std::pair<std::uint16_t, std::size_t>, int> datagrams;  ///< (port, size) -> count
  std::uint64_t incomplete;
};

class PcapRealCaptures : public ::testing::TestWithParam<RealCapture> {};

TEST_P(PcapRealCaptures, DatagramsPerPortAndSize) {
  const std::string path = test::shared_data(std::string("ouster/") + GetParam().file);
  FUSE_REQUIRE_SHARED(path);
  pcap::PcapReader r(path);
  std::map<std::pair<std::uint16_t, std::size_t>, int> got;
  pcap::UdpDatagram d;
  double last = 0.0;
  while (r.next(d)) {
    ++got[{d.dst_port, d.payload.size()}];
    EXPECT_GT(d.capture_time, 1.5e9);
    EXPECT_GE(d.capture_time, last);
    last = d.capture_time;
  }
  EXPECT_EQ(got, GetParam().datagrams);
  const auto it = r.skipped().find(pcap::skip::kIncompleteFragments);
  EXPECT_EQ(it == r.skipped().end() ? 0u : it->second, GetParam().incomplete);
}

INSTANTIATE_TEST_SUITE_P(
    Ouster, PcapRealCaptures,
    ::testing::Values(RealCapture{"OS-1-128_v2.3.0_1024x10_lb_n3.pcap", {{{7502, 8448}, 192}, {{7503, 48}, 30}}, 0},
                      RealCapture{"OS-2-128-U1_v2.3.0_1024x10.pcap", {{{7502, 24832}, 64}, {{7503, 48}, 10}}, 0},
                      RealCapture{"same_ports.pcap", {{{7502, 48}, 2}, {{7502, 12608}, 1}, {{7502, 16640}, 1}}, 0},
                      RealCapture{"same_ports_legacy.pcap", {{{7502, 12608}, 1}, {{7502, 24896}, 1}}, 0},
                      // The first datagram's identification is reused 88 s later: only the second completes.
                      RealCapture{"duplicate_id.pcap", {{{34636, 8448}, 1}}, 1},
                      RealCapture{"empty_pcap.pcap", {}, 0}),
    [](const auto& info) {
      std::string n = info.param.file;
      for (char& c : n) {
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      }
      return n;
    });

}  // namespace
}  // namespace fuse::io

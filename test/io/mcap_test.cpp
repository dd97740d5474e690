// MCAP reader and writer: the real rosbag2 file, round trips for every compression, time-range
// seeks through the chunk index, and truncated / corrupted files (InputError, never a crash;
// truncated files are salvaged: the complete messages first, then InputError).
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <vector>

#include "fuse/io/compression.hpp"
#include "fuse/io/crc32.hpp"
#include "fuse/io/mcap_reader.hpp"
#include "fuse/io/mcap_writer.hpp"
#include "test_util.hpp"

namespace fuse::io {
namespace {

using test::TempDir;

const std::string kNav2 = "recordings/nav2_turtlebot.mcap";

TEST(Crc32, KnownValue) {
  // Standard check value of CRC-32/ISO-HDLC for "123456789".
  EXPECT_EQ(crc32("123456789", 9), 0xCBF43926u);
}

// The word-at-a-time update against the definition (one bit at a time), over lengths around the
// 8-byte step, unaligned starts and updates split at odd places.
TEST(Crc32, MatchesTheBitwiseDefinition) {
  const auto bitwise = [](const std::uint8_t* p, std::size_t n) {
    std::uint32_t c = 0xFFFFFFFFu;
    for (std::size_t i = 0; i < n; ++i) {
      c ^= p[i];
      for (int b = 0; b < 8; ++b) c = (c & 1u) ? (0xEDB88320u ^ (c >> 1)) : (c >> 1);
    }
    return c ^ 0xFFFFFFFFu;
  };
  std::vector<std::uint8_t> data(300);
  std::uint32_t x = 12345;
  for (auto& b : data) b = static_cast<std::uint8_t>((x = x * 1664525u + 1013904223u) >> 24);
  for (std::size_t start = 0; start < 9; ++start) {
    for (std::size_t n = 0; start + n <= data.size(); n += (n < 40 ? 1 : 37)) {
      EXPECT_EQ(crc32(data.data() + start, n), bitwise(data.data() + start, n)) << "start " << start << ", " << n << " bytes";
      Crc32 split;
      split.update(data.data() + start, n / 3);
      split.update(data.data() + start + n / 3, n - n / 3);
      EXPECT_EQ(split.value(), bitwise(data.data() + start, n)) << "split, start " << start << ", " << n << " bytes";
    }
  }
}

// Reads every message of a real rosbag2 file and checks counts and time range against the
// file's own Statistics record.
TEST(McapReader, Rosbag2FileMatchesItsStatistics) {
  const std::string path = test::shared_data(kNav2);
  FUSE_REQUIRE_SHARED(path);
  McapReader reader(path);
  EXPECT_EQ(reader.header().profile, "ros2");
  EXPECT_TRUE(reader.has_summary());
  ASSERT_TRUE(reader.statistics().has_value());
  const auto& stats = *reader.statistics();
  EXPECT_EQ(reader.chunk_indexes().size(), 1u);
  EXPECT_EQ(reader.channels().size(), stats.channel_count);

  std::map<std::uint16_t, std::uint64_t> counts;
  std::uint64_t total = 0, first = 0, last = 0, previous = 0;
  McapMessage m;
  reader.start();
  while (reader.next(m)) {
    ASSERT_NE(m.channel, nullptr);
    ASSERT_NE(m.schema, nullptr);
    EXPECT_EQ(m.channel->message_encoding, "cdr");
    EXPECT_GE(m.header.log_time, previous) << "log-time order";
    previous = m.header.log_time;
    if (total == 0) first = m.header.log_time;
    last = m.header.log_time;
    ++counts[m.header.channel_id];
    ++total;
  }
  EXPECT_GT(total, 0u);
  EXPECT_EQ(total, stats.message_count);
  EXPECT_EQ(counts, stats.channel_message_counts);
  EXPECT_EQ(first, stats.message_start_time);
  EXPECT_EQ(last, stats.message_end_time);
  EXPECT_EQ(reader.blocks_loaded(), 1u);
  EXPECT_NO_THROW(reader.verify());

  // File order yields the same messages.
  reader.start({0, UINT64_MAX, ReadOrder::kFile});
  std::uint64_t file_order_total = 0;
  while (reader.next(m)) ++file_order_total;
  EXPECT_EQ(file_order_total, total);
}

struct TestMessage {
  std::uint16_t channel;
  std::uint32_t sequence;
  std::uint64_t log_time;
  std::vector<std::uint8_t> data;
};

std::vector<TestMessage> make_messages(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<TestMessage> out;
  std::uint64_t t = 1'000'000'000;
  for (std::size_t i = 0; i < n; ++i) {
    TestMessage m;
    m.channel = static_cast<std::uint16_t>(i % 3 == 0 ? 1 : 0);
    m.sequence = static_cast<std::uint32_t>(i);
    t += 1'000'000 + rng() % 1000;
    m.log_time = t;
    m.data.resize(m.channel == 1 ? 2000 + rng() % 3000 : 40 + rng() % 20);
    for (auto& b : m.data) b = static_cast<std::uint8_t>(rng() % 7);  // compressible
    out.push_back(std::move(m));
  }
  return out;
}

void write_file(const std::string& path, const McapWriterOptions& options, const std::vector<TestMessage>& messages) {
  McapWriter w(path, options);
  const auto s = w.add_schema("test::A", "omgidl", "struct A { long x; };");
  EXPECT_EQ(s, 1);
  EXPECT_EQ(w.add_channel(s, "small", "cdr"), 0);
  EXPECT_EQ(w.add_channel(s, "big", "cdr", {{"k", "v"}}), 1);
  w.write_metadata("fuse.test", {{"a", "1"}, {"b", "two"}});
  for (const auto& m : messages) w.write_message(m.channel, m.sequence, m.log_time, m.log_time + 5, m.data.data(), m.data.size());
  w.close();
}

std::vector<McapMessage> read_all(McapReader& r, const McapReadOptions& options = {}) {
  std::vector<McapMessage> out;
  McapMessage m;
  r.start(options);
  while (r.next(m)) out.push_back(m);
  return out;
}

class McapRoundTrip : public ::testing::TestWithParam<Compression> {};

TEST_P(McapRoundTrip, WritesAndReadsBack) {
  TempDir dir;
  const auto messages = make_messages(400, 7);
  for (const bool chunks : {true, false}) {
    for (const bool summary : {true, false}) {
      McapWriterOptions options;
      options.compression = GetParam();
      options.chunk_size_bytes = 64 * 1024;
      options.use_chunks = chunks;
      options.write_summary = summary;
      const std::string path = dir.file("rt.mcap");
      write_file(path, options, messages);
      SCOPED_TRACE("chunks=" + std::to_string(chunks) + " summary=" + std::to_string(summary));

      McapReader r(path);
      EXPECT_EQ(r.has_summary(), chunks && summary);
      ASSERT_EQ(r.channels().size(), 2u);
      EXPECT_EQ(r.channels().at(1).metadata.at("k"), "v");
      ASSERT_EQ(r.schemas().size(), 1u);
      EXPECT_EQ(r.schemas().at(1).encoding, "omgidl");
      ASSERT_EQ(r.metadata().size(), 1u);
      EXPECT_EQ(r.metadata()[0].name, "fuse.test");
      EXPECT_EQ(r.metadata()[0].metadata.at("b"), "two");
      if (summary) {
        ASSERT_TRUE(r.statistics().has_value());
        EXPECT_EQ(r.statistics()->message_count, messages.size());
        EXPECT_EQ(r.statistics()->metadata_count, 1u);
        EXPECT_EQ(r.statistics()->channel_count, 2u);
        EXPECT_EQ(r.statistics()->message_start_time, messages.front().log_time);
        EXPECT_EQ(r.statistics()->message_end_time, messages.back().log_time);
        if (chunks) {
          EXPECT_GT(r.statistics()->chunk_count, 5u);
          EXPECT_EQ(r.chunk_indexes().size(), r.statistics()->chunk_count);
        }
      }
      const auto got = read_all(r);
      ASSERT_EQ(got.size(), messages.size());
      for (std::size_t i = 0; i < got.size(); ++i) {
        EXPECT_EQ(got[i].header.channel_id, messages[i].channel);
        EXPECT_EQ(got[i].header.sequence, messages[i].sequence);
        EXPECT_EQ(got[i].header.log_time, messages[i].log_time);
        EXPECT_EQ(got[i].header.publish_time, messages[i].log_time + 5);
        EXPECT_EQ(got[i].data, messages[i].data);
        EXPECT_EQ(got[i].channel->topic, messages[i].channel == 1 ? "big" : "small");
      }
      EXPECT_NO_THROW(r.verify());
    }
  }
}

// One output buffer for chunk after chunk, as the reader uses it: a large chunk, then a small
// one into the large one's capacity, then a large one again; a truncated chunk is an error
// after the buffer has grown.
TEST_P(McapRoundTrip, DecompressesIntoAReusedBuffer) {
  const auto bytes = [](std::size_t n, std::uint8_t seed) {
    std::vector<std::uint8_t> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<std::uint8_t>((i * 7 + seed) % 251 ^ (i >> 9));
    return v;
  };
  const char* name = compression_name(GetParam());
  std::vector<std::uint8_t> out;
  for (const auto& [n, seed] : {std::pair<std::size_t, std::uint8_t>{1 << 20, 1}, {1000, 2}, {300000, 3}}) {
    const auto plain = bytes(n, seed);
    const auto packed = compress(GetParam(), plain.data(), plain.size());
    decompress_into(name, packed.data(), packed.size(), plain.size(), "chunk", out);
    EXPECT_EQ(out, plain) << n << " bytes";
  }
  EXPECT_GE(out.capacity(), std::size_t{1} << 20) << "the first chunk's buffer is kept";
  const auto plain = bytes(5000, 5);
  const auto packed = compress(GetParam(), plain.data(), plain.size());
  EXPECT_THROW(decompress_into(name, packed.data(), packed.size() - 1, plain.size(), "chunk", out), InputError);
  EXPECT_THROW(decompress_into(name, packed.data(), packed.size(), plain.size() + 1, "chunk", out), InputError);
}

INSTANTIATE_TEST_SUITE_P(AllCompressions, McapRoundTrip,
                         ::testing::Values(Compression::kNone, Compression::kZstd, Compression::kLz4),
                         [](const auto& info) {
                           return info.param == Compression::kNone ? std::string("none")
                                                                   : std::string(compression_name(info.param));
                         });

// Seek by time: only the chunks overlapping the range are loaded, and exactly the messages in
// the range come back, in log-time order.
TEST(McapReader, TimeRangeLoadsOnlyOverlappingChunks) {
  TempDir dir;
  const auto messages = make_messages(600, 3);
  McapWriterOptions options;
  options.chunk_size_bytes = 32 * 1024;
  write_file(dir.file("seek.mcap"), options, messages);
  McapReader r(dir.file("seek.mcap"));
  const std::size_t chunks = r.chunk_indexes().size();
  ASSERT_GT(chunks, 10u);
  const std::uint64_t t0 = messages[250].log_time, t1 = messages[300].log_time;
  const auto got = read_all(r, {t0, t1, ReadOrder::kLogTime});
  ASSERT_EQ(got.size(), 51u);
  for (std::size_t i = 0; i < got.size(); ++i) EXPECT_EQ(got[i].header.sequence, 250 + i);
  std::size_t overlapping = 0;
  for (const auto& ci : r.chunk_indexes()) overlapping += ci.message_end_time >= t0 && ci.message_start_time <= t1;
  EXPECT_EQ(r.blocks_loaded(), overlapping);
  EXPECT_LT(r.blocks_loaded(), chunks / 3);
  // A range beyond the end loads nothing.
  EXPECT_TRUE(read_all(r, {messages.back().log_time + 1, UINT64_MAX, ReadOrder::kLogTime}).empty());
  EXPECT_EQ(r.blocks_loaded(), 0u);
}

// Messages written out of log-time order (within and across chunks) come back sorted; file
// order gives them as written.
TEST(McapReader, MergesOverlappingChunksInLogTimeOrder) {
  TempDir dir;
  auto messages = make_messages(300, 11);
  std::mt19937 rng(5);
  for (auto& m : messages) m.log_time += rng() % 40'000'000;  // jitter larger than the spacing
  McapWriterOptions options;
  options.chunk_size_bytes = 16 * 1024;
  write_file(dir.file("ooo.mcap"), options, messages);
  McapReader r(dir.file("ooo.mcap"));
  const auto sorted = read_all(r);
  ASSERT_EQ(sorted.size(), messages.size());
  EXPECT_TRUE(std::is_sorted(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) {
    return a.header.log_time < b.header.log_time;
  }));
  const auto in_file = read_all(r, {0, UINT64_MAX, ReadOrder::kFile});
  ASSERT_EQ(in_file.size(), messages.size());
  for (std::size_t i = 0; i < in_file.size(); ++i) EXPECT_EQ(in_file[i].header.sequence, messages[i].sequence);
}

/// Opens, reads everything and verifies; returns true when an InputError was raised. Any other
/// exception fails the test.
bool fails_with_input_error(const std::string& path, bool verify) {
  try {
    McapReader r(path);
    McapMessage m;
    r.start();
    while (r.next(m)) {
    }
    if (verify) r.verify();
    return false;
  } catch (const InputError& e) {
    EXPECT_GT(std::string(e.what()).size(), 10u);
    return true;
  }
}

std::vector<std::size_t> sample_offsets(std::size_t size, std::size_t count) {
  std::vector<std::size_t> offsets;
  for (std::size_t i = 0; i < 64 && i < size; ++i) offsets.push_back(i);  // magic, header
  for (std::size_t i = 0; i < count; ++i) offsets.push_back(size * i / count);
  for (std::size_t i = 1; i <= 128 && i < size; ++i) offsets.push_back(size - i);  // summary, footer
  return offsets;
}

/// Reads in file order until the end or an InputError (its text goes to `error`).
std::vector<McapMessage> read_until_error(McapReader& r, std::string& error) {
  std::vector<McapMessage> out;
  try {
    McapMessage m;
    r.start({0, UINT64_MAX, ReadOrder::kFile});
    while (r.next(m)) out.push_back(m);
  } catch (const InputError& e) {
    error = e.what();
  }
  return out;
}

void expect_same_message(const McapMessage& a, const McapMessage& b) {
  EXPECT_EQ(a.header.channel_id, b.header.channel_id);
  EXPECT_EQ(a.header.sequence, b.header.sequence);
  EXPECT_EQ(a.header.log_time, b.header.log_time);
  EXPECT_EQ(a.data, b.data);
}

// Every truncated file ends in InputError (at open when the Header is cut, else after salvage),
// and what salvage returns is a prefix of the full file's messages.
void check_truncations(const std::string& source, TempDir& dir) {
  std::string error;
  McapReader whole(source);
  const auto all = read_until_error(whole, error);
  ASSERT_TRUE(error.empty()) << error;
  const auto bytes = test::read_bytes(source);
  const std::string copy = dir.file("truncated.mcap");
  for (const std::size_t n : sample_offsets(bytes.size(), 150)) {
    SCOPED_TRACE("truncated to " + std::to_string(n) + " bytes");
    test::write_bytes(copy, bytes, n);
    EXPECT_TRUE(fails_with_input_error(copy, false));
    try {
      McapReader r(copy);
      EXPECT_TRUE(r.salvage_mode());
      error.clear();
      const auto got = read_until_error(r, error);
      EXPECT_NE(error.find("truncated"), std::string::npos) << error;
      ASSERT_LE(got.size(), all.size());
      for (std::size_t i = 0; i < got.size(); ++i) expect_same_message(got[i], all[i]);
    } catch (const InputError&) {  // the Header is cut: nothing to salvage
    }
  }
}

TEST(McapReader, TruncatedFilesRaiseInputError) {
  TempDir dir;
  McapWriterOptions options;
  options.chunk_size_bytes = 16 * 1024;
  write_file(dir.file("own.mcap"), options, make_messages(200, 1));
  check_truncations(dir.file("own.mcap"), dir);
  const std::string nav2 = test::shared_data(kNav2);
  FUSE_REQUIRE_SHARED(nav2);
  check_truncations(nav2, dir);
}

/// Chunk `index` of a complete file, from its summary.
mcap::ChunkIndex chunk_at(const std::string& path, std::size_t index) {
  McapReader r(path);
  EXPECT_GT(r.chunk_indexes().size(), index);
  return r.chunk_indexes().at(index);
}

// Salvage stops at the first Chunk failing its CRC, even when later chunks are intact: the
// messages before it come back, then InputError names that chunk and its offset.
TEST(McapReader, SalvageStopsAtAChunkFailingItsCrc) {
  TempDir dir;
  McapWriterOptions options;
  options.compression = Compression::kNone;  // a flipped byte reaches the CRC check
  options.chunk_size_bytes = 16 * 1024;
  const auto messages = make_messages(200, 4);
  write_file(dir.file("own.mcap"), options, messages);
  const auto bad = chunk_at(dir.file("own.mcap"), 2), later = chunk_at(dir.file("own.mcap"), 5);
  auto bytes = test::read_bytes(dir.file("own.mcap"));
  bytes[bad.chunk_start_offset + bad.chunk_length - 10] ^= 0x5A;  // inside the chunk's records
  test::write_bytes(dir.file("cut.mcap"), bytes, later.chunk_start_offset + later.chunk_length / 2);

  McapReader r(dir.file("cut.mcap"));
  ASSERT_TRUE(r.salvage_mode());
  std::string error;
  const auto got = read_until_error(r, error);
  ASSERT_GT(got.size(), 0u);
  ASSERT_LT(got.size(), messages.size());
  for (std::size_t i = 0; i < got.size(); ++i) EXPECT_EQ(got[i].header.sequence, messages[i].sequence);
  // Log times increase strictly, so the chunks before the damaged one hold exactly these.
  const auto before = std::count_if(messages.begin(), messages.end(),
                                    [&](const TestMessage& m) { return m.log_time < bad.message_start_time; });
  EXPECT_EQ(got.size(), static_cast<std::size_t>(before));
  EXPECT_NE(error.find("truncated"), std::string::npos) << error;
  EXPECT_NE(error.find("Chunk record at offset " + std::to_string(bad.chunk_start_offset)), std::string::npos) << error;
  EXPECT_NE(error.find("CRC mismatch"), std::string::npos) << error;
  EXPECT_THROW(r.verify(), InputError);
}

// A complete, indexed file with a damaged chunk is not salvaged: the error names the chunk.
TEST(McapReader, CorruptChunkInACompleteFileIsAnErrorNamingIt) {
  TempDir dir;
  McapWriterOptions options;
  options.compression = Compression::kNone;
  options.chunk_size_bytes = 16 * 1024;
  write_file(dir.file("own.mcap"), options, make_messages(200, 4));
  const auto bad = chunk_at(dir.file("own.mcap"), 3);
  auto bytes = test::read_bytes(dir.file("own.mcap"));
  bytes[bad.chunk_start_offset + bad.chunk_length - 10] ^= 0x5A;
  test::write_bytes(dir.file("bad.mcap"), bytes, bytes.size());

  McapReader r(dir.file("bad.mcap"));
  EXPECT_FALSE(r.salvage_mode());
  EXPECT_TRUE(r.has_summary());
  std::string error;
  read_until_error(r, error);
  EXPECT_NE(error.find("Chunk record at offset " + std::to_string(bad.chunk_start_offset)), std::string::npos) << error;
  EXPECT_EQ(error.find("salvage"), std::string::npos) << error;
}

// A complete file whose summary fails its CRC: the data section is scanned (salvage), every
// message comes back, then InputError reports the unreadable summary.
TEST(McapReader, UnreadableSummaryIsSalvagedThenReported) {
  TempDir dir;
  McapWriterOptions options;
  options.chunk_size_bytes = 16 * 1024;
  const auto messages = make_messages(150, 6);
  write_file(dir.file("own.mcap"), options, messages);
  auto bytes = test::read_bytes(dir.file("own.mcap"));
  bytes[bytes.size() - 60] ^= 0x5A;  // inside the summary offsets, before the Footer
  test::write_bytes(dir.file("bad.mcap"), bytes, bytes.size());

  McapReader r(dir.file("bad.mcap"));
  EXPECT_TRUE(r.salvage_mode());
  EXPECT_FALSE(r.has_summary());
  ASSERT_EQ(r.metadata().size(), 1u);
  std::string error;
  const auto got = read_until_error(r, error);
  ASSERT_EQ(got.size(), messages.size());
  for (std::size_t i = 0; i < got.size(); ++i) EXPECT_EQ(got[i].data, messages[i].data);
  EXPECT_NE(error.find("summary section unreadable"), std::string::npos) << error;
  EXPECT_NE(error.find("DataEnd record reached"), std::string::npos) << error;
}

// Our files carry every CRC: a flipped byte anywhere is detected (at open, while reading, or
// by verify()).
TEST(McapReader, CorruptedOwnFilesRaiseInputError) {
  TempDir dir;
  for (const auto c : {Compression::kNone, Compression::kZstd, Compression::kLz4}) {
    McapWriterOptions options;
    options.compression = c;
    options.chunk_size_bytes = 16 * 1024;
    write_file(dir.file("own.mcap"), options, make_messages(120, 2));
    auto bytes = test::read_bytes(dir.file("own.mcap"));
    for (const std::size_t offset : sample_offsets(bytes.size(), 300)) {
      auto corrupted = bytes;
      corrupted[offset] ^= 0x5A;
      test::write_bytes(dir.file("bad.mcap"), corrupted, corrupted.size());
      EXPECT_TRUE(fails_with_input_error(dir.file("bad.mcap"), true))
          << compression_name(c) << ": flip at offset " << offset << " of " << bytes.size() << " not detected";
    }
  }
}

// The rosbag2 file has no CRCs (all 0): corruption may go unnoticed, but must never crash or
// raise anything but InputError.
TEST(McapReader, CorruptedRosbag2FileNeverCrashes) {
  const std::string nav2 = test::shared_data(kNav2);
  FUSE_REQUIRE_SHARED(nav2);
  TempDir dir;
  const auto bytes = test::read_bytes(nav2);
  std::size_t detected = 0, total = 0;
  for (const std::size_t offset : sample_offsets(bytes.size(), 200)) {
    for (const std::uint8_t mask : {0x01, 0xFF}) {
      auto corrupted = bytes;
      corrupted[offset] ^= mask;
      test::write_bytes(dir.file("bad.mcap"), corrupted, corrupted.size());
      detected += fails_with_input_error(dir.file("bad.mcap"), true);
      ++total;
    }
  }
  std::printf("rosbag2 file: %zu of %zu single-byte corruptions detected\n", detected, total);
  EXPECT_GT(detected, total / 4);
}

TEST(McapReader, RejectsNonMcapInput) {
  TempDir dir;
  test::write_bytes(dir.file("empty.mcap"), {}, 0);
  EXPECT_THROW(McapReader(dir.file("empty.mcap")), InputError);
  std::vector<std::uint8_t> junk(1000, 0x42);
  test::write_bytes(dir.file("junk.mcap"), junk, junk.size());
  EXPECT_THROW(McapReader(dir.file("junk.mcap")), InputError);
  EXPECT_THROW(McapReader(dir.file("missing.mcap")), InputError);
}

}  // namespace
}  // namespace fuse::io

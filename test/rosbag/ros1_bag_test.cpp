// ROS 1 bag v2.0 reader on the real bags in ../shared/data/recordings (written by rosbag and by
// the rosbags library): topics, types, counts, time range, every message read in time order and
// counted against the index; the same contents re-chunked with none/bz2/lz4; truncated and
// damaged files give InputError, never a crash.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <random>

#include "fuse/io/sensor_source.hpp"
#include "fuse/rosbag/ros1_bag_reader.hpp"
#include "ros1_bag_writer.hpp"

namespace fuse::rosbag {
namespace {

namespace fs = std::filesystem;

struct TopicExpect {
  std::string type;
  std::uint64_t count;
};

struct BagExpect {
  std::string file;
  std::map<std::string, TopicExpect> topics;
  std::uint64_t start_ns, end_ns;
  std::string compression;
};

// Counts and time ranges: tf_example.bag holds the same data as rosbag2_tf_example/ (its
// metadata.yaml, written by another tool, gives 1 + 517 messages from 1714741164111822142 ns over
// 51684723334 ns); the ouster bag holds about one 512x10 frame (32 lidar packets of 16 columns)
// and 10 IMU packets at 100 Hz; ROS_example.bag is evo's test bag of three PoseStamped topics.
const std::vector<BagExpect> kBags = {
    {"ROS_example.bag",
     {{"groundtruth", {"geometry_msgs/PoseStamped", 12765}},
      {"ORB-SLAM", {"geometry_msgs/PoseStamped", 8362}},
      {"S-PTAM", {"geometry_msgs/PoseStamped", 5439}}},
     1502792570283404827ull,
     1502793459302349567ull,
     "none"},
    {"tf_example.bag",
     {{"/tf_static", {"tf2_msgs/TFMessage", 1}}, {"/tf", {"tf2_msgs/TFMessage", 517}}},
     1714741164111822142ull,
     1714741164111822142ull + 51684723334ull,
     "lz4"},
    {"ouster_512x10_raw.bag",
     {{"/os_node0/imu_packets", {"ouster_ros/PacketMsg", 10}},
      {"/os_node0/lidar_packets", {"ouster_ros/PacketMsg", 32}},
      {"/os_node0/metadata", {"std_msgs/String", 1}}},
     1723828414279578824ull,
     1723828414376097122ull,
     "none"},
};

std::string recordings() { return std::string(FUSE_SHARED_DATA) + "/recordings"; }

#define SKIP_WITHOUT_DATA(path)                                                                       \
  if (!fs::exists(path)) GTEST_SKIP() << "shared data not found at " << (path)                        \
                                      << " (set -DFUSE_SHARED_DATA=...); real-bag test skipped";

class RealBag : public ::testing::TestWithParam<BagExpect> {};

TEST_P(RealBag, TopicsTypesCountsAndTimeRangeByReadingEveryMessage) {
  const BagExpect& e = GetParam();
  const std::string path = recordings() + "/" + e.file;
  SKIP_WITHOUT_DATA(path);
  Ros1BagReader bag(path);
  EXPECT_FALSE(bag.salvage_mode());
  ASSERT_FALSE(bag.chunks().empty());
  for (const auto& c : bag.chunks()) EXPECT_EQ(c.compression, e.compression);

  // The index (chunk info records).
  ASSERT_EQ(bag.connections().size(), e.topics.size());
  const auto indexed = bag.indexed_counts();
  for (const auto& [id, c] : bag.connections()) {
    ASSERT_TRUE(e.topics.count(c.topic)) << c.topic;
    EXPECT_EQ(c.type, e.topics.at(c.topic).type);
    EXPECT_EQ(c.md5sum.size(), 32u);
    EXPECT_FALSE(c.message_definition.empty());
    EXPECT_EQ(indexed.at(id), e.topics.at(c.topic).count) << c.topic;
  }
  EXPECT_EQ(bag.start_time_ns(), e.start_ns);
  EXPECT_EQ(bag.end_time_ns(), e.end_ns);

  // Every message, decompressed and counted.
  bag.start();
  Ros1Message m;
  std::map<std::string, std::uint64_t> counts;
  std::uint64_t first = 0, last = 0, n = 0;
  while (bag.next(m)) {
    ASSERT_NE(m.connection, nullptr);
    if (n == 0) first = m.time_ns;
    ASSERT_GE(m.time_ns, last) << "message " << n << " out of time order";
    last = m.time_ns;
    ++counts[m.connection->topic];
    ++n;
  }
  EXPECT_EQ(first, e.start_ns);
  EXPECT_EQ(last, e.end_ns);
  for (const auto& [topic, t] : e.topics) EXPECT_EQ(counts[topic], t.count) << topic;
  EXPECT_EQ(n, bag.message_count());
  EXPECT_EQ(bag.chunks_loaded(), bag.chunks().size());
}

INSTANTIATE_TEST_SUITE_P(Recordings, RealBag, ::testing::ValuesIn(kBags),
                         [](const auto& info) {
                           std::string s = info.param.file.substr(0, info.param.file.find('.'));
                           for (auto& ch : s) if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return s;
                         });

TEST(Ros1Bag, OusterPacketsByTopicFilter) {
  const std::string path = recordings() + "/ouster_512x10_raw.bag";
  SKIP_WITHOUT_DATA(path);
  Ros1BagReader bag(path);
  bag.start({{"/os_node0/lidar_packets"}});
  Ros1Message m;
  int n = 0;
  while (bag.next(m)) {
    EXPECT_EQ(m.connection->topic, "/os_node0/lidar_packets");
    // ouster_ros/PacketMsg is `uint8[] buf`: a uint32 length, then that many bytes.
    ASSERT_GE(m.data.size(), 4u);
    std::uint32_t len;
    std::memcpy(&len, m.data.data(), 4);
    EXPECT_EQ(len + 4u, m.data.size());
    ++n;
  }
  EXPECT_EQ(n, 32);
}

/// All messages and connections of a real bag, to be written again.
void slurp(const std::string& path, std::vector<test::WriterConnection>& conns, std::vector<test::WriterMessage>& msgs) {
  Ros1BagReader bag(path);
  for (const auto& [id, c] : bag.connections()) conns.push_back({id, c.topic, c.type, c.md5sum, c.message_definition});
  bag.start();
  Ros1Message m;
  while (bag.next(m)) msgs.push_back({m.connection->id, m.time_ns, m.data});
}

class Compression : public ::testing::TestWithParam<std::string> {};

TEST_P(Compression, RechunkedRealBagReadsBackTheSameMessages) {
  const std::string src = recordings() + "/tf_example.bag";
  SKIP_WITHOUT_DATA(src);
  std::vector<test::WriterConnection> conns;
  std::vector<test::WriterMessage> msgs;
  slurp(src, conns, msgs);
  const std::string out = ::testing::TempDir() + "/rechunk_" + GetParam() + ".bag";
  test::write_file(out, test::write_bag(conns, msgs, GetParam(), 100));
  Ros1BagReader bag(out);
  EXPECT_EQ(bag.chunks().size(), 6u);
  for (const auto& c : bag.chunks()) EXPECT_EQ(c.compression, GetParam());
  bag.start();
  Ros1Message m;
  std::size_t i = 0;
  while (bag.next(m)) {
    ASSERT_LT(i, msgs.size());
    EXPECT_EQ(m.connection->id, msgs[i].conn);
    EXPECT_EQ(m.time_ns, msgs[i].time_ns);
    EXPECT_EQ(m.data, msgs[i].data);
    ++i;
  }
  EXPECT_EQ(i, msgs.size());
  fs::remove(out);
}

INSTANTIATE_TEST_SUITE_P(Chunks, Compression, ::testing::Values("none", "bz2", "lz4"),
                         [](const auto& info) { return info.param; });

TEST(Ros1Bag, OverlappingChunksAreMergedInTimeOrder) {
  std::vector<test::WriterConnection> conns = {{0, "/a", "std_msgs/Empty", std::string(32, '0'), ""},
                                               {1, "/b", "std_msgs/Empty", std::string(32, '0'), ""}};
  std::vector<test::WriterMessage> msgs;
  // Two chunks whose time ranges interleave (a recorder writing two slow topics).
  for (int i = 0; i < 10; ++i) msgs.push_back({0, 1000000000ull + 2 * i, {std::uint8_t(i)}});
  for (int i = 0; i < 10; ++i) msgs.push_back({1, 1000000000ull + 2 * i + 1, {std::uint8_t(100 + i)}});
  const std::string out = ::testing::TempDir() + "/overlap.bag";
  test::write_file(out, test::write_bag(conns, msgs, "bz2", 10));
  Ros1BagReader bag(out);
  bag.start();
  Ros1Message m;
  std::uint64_t expect = 1000000000ull;
  while (bag.next(m)) EXPECT_EQ(m.time_ns, expect++);
  EXPECT_EQ(expect, 1000000000ull + 20);
  fs::remove(out);
}

/// Opens and reads a whole bag; returns the InputError text, or "" when it read cleanly.
std::string read_all(const std::string& path, std::size_t* messages = nullptr) {
  try {
    Ros1BagReader bag(path);
    bag.start();
    Ros1Message m;
    std::size_t n = 0;
    while (bag.next(m)) ++n;
    if (messages) *messages = n;
    return "";
  } catch (const io::InputError& e) {
    return e.what();
  }
}

std::vector<std::uint8_t> file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(f), {});
}

TEST(Ros1Bag, TruncatedFilesGiveAnInputError) {
  for (const auto& e : kBags) {
    const std::string path = recordings() + "/" + e.file;
    SKIP_WITHOUT_DATA(path);
    const auto bytes = file_bytes(path);
    for (double f : {0.0, 0.001, 0.01, 0.3, 0.5, 0.9, 0.999}) {
      const std::size_t n = static_cast<std::size_t>(f * static_cast<double>(bytes.size()));
      const std::string out = ::testing::TempDir() + "/truncated.bag";
      test::write_file(out, std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(n)));
      const std::string err = read_all(out);
      EXPECT_FALSE(err.empty()) << e.file << " cut at " << n << " bytes read without error";
      EXPECT_NE(err.find("truncated.bag"), std::string::npos) << err;  // names the file
    }
  }
}

TEST(Ros1Bag, UnclosedBagIsSalvagedUpToItsLastCompleteChunk) {
  std::vector<test::WriterConnection> conns = {{0, "/a", "std_msgs/Empty", std::string(32, '0'), ""}};
  std::vector<test::WriterMessage> msgs;
  for (int i = 0; i < 30; ++i) msgs.push_back({0, 1000000000ull + i, {std::uint8_t(i)}});
  auto bytes = test::write_bag(conns, msgs, "lz4", 10);
  // Cut inside the third chunk: the first two chunks (20 messages) remain.
  Ros1BagReader full_bag(([&] {
    const std::string p = ::testing::TempDir() + "/full.bag";
    test::write_file(p, bytes);
    return p;
  })());
  const std::uint64_t cut = full_bag.chunks()[2].data_pos + 5;
  bytes.resize(cut);
  const std::string out = ::testing::TempDir() + "/unclosed.bag";
  test::write_file(out, bytes);
  Ros1BagReader bag(out);
  EXPECT_TRUE(bag.salvage_mode());
  bag.start();
  Ros1Message m;
  int n = 0;
  try {
    while (bag.next(m)) ++n;
    ADD_FAILURE() << "no error at the end of a cut-off bag";
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("file ends inside the record data"), std::string::npos) << e.what();
  }
  EXPECT_EQ(n, 20);
}

TEST(Ros1Bag, DamagedBytesGiveAnInputErrorOrTheMessagesNeverACrash) {
  const std::string path = recordings() + "/tf_example.bag";
  SKIP_WITHOUT_DATA(path);
  const auto bytes = file_bytes(path);
  std::mt19937 rng(7);
  int errors = 0;
  for (int trial = 0; trial < 300; ++trial) {
    auto damaged = bytes;
    // Damage the first 5000 bytes (bag header, chunk header, lz4 frame start) or anywhere.
    const std::size_t range = trial % 2 ? 5000 : damaged.size();
    for (int k = 0; k < 4; ++k) damaged[rng() % range] ^= static_cast<std::uint8_t>(1 + rng() % 255);
    const std::string out = ::testing::TempDir() + "/damaged.bag";
    test::write_file(out, damaged);
    if (!read_all(out).empty()) ++errors;
  }
  EXPECT_GT(errors, 100);  // most damage is detected (lz4 checks, lengths, counts)
}

TEST(Ros1Bag, ClearErrors) {
  const std::string out = ::testing::TempDir() + "/not_a_bag.bag";
  test::write_file(out, std::vector<std::uint8_t>{'#', 'R', 'O', 'S', 'B', 'A', 'G', ' ', 'V', '1', '.', '2', '\n'});
  EXPECT_NE(read_all(out).find("not a ROS bag v2.0"), std::string::npos);
  EXPECT_NE(read_all(::testing::TempDir() + "/does_not_exist.bag").find("cannot open"), std::string::npos);

  // A chunk whose index claims more messages than it holds.
  std::vector<test::WriterConnection> conns = {{0, "/a", "std_msgs/Empty", std::string(32, '0'), ""}};
  std::vector<test::WriterMessage> msgs = {{0, 5, {1}}, {0, 6, {2}}};
  auto bytes = test::write_bag(conns, msgs, "none", 10);
  // The chunk info's count is the last 4 bytes of the file (connection 0, count 2).
  bytes[bytes.size() - 4] = 3;
  test::write_file(out, bytes);
  EXPECT_NE(read_all(out).find("differ from the index"), std::string::npos) << read_all(out);
}

}  // namespace
}  // namespace fuse::rosbag

// rosbag2 readers on the real files in ../shared/data/recordings: nav2_turtlebot.mcap (MCAP
// storage, written by rosbag2_storage_mcap) and rosbag2_tf_example/ (sqlite3 storage with
// metadata.yaml): topics, types, counts, time range, every message read (CDR with its 4-byte
// encapsulation header); the same data in ROS 1 and rosbag2 form gives the same message times;
// bad directories and files give InputError.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>

#include "fuse/io/sensor_source.hpp"
#include "fuse/rosbag/bag_reader.hpp"

namespace fuse::rosbag {
namespace {

namespace fs = std::filesystem;

struct Expect {
  std::string path;  ///< under recordings/
  std::map<std::string, std::pair<std::string, std::uint64_t>> topics;  ///< name -> (type, count)
  std::uint64_t start_ns, end_ns;
};

const std::vector<Expect> kInputs = {
    {"nav2_turtlebot.mcap",
     {{"/odom", {"nav_msgs/msg/Odometry", 2639}},
      {"/tf", {"tf2_msgs/msg/TFMessage", 5422}},
      {"/tf_static", {"tf2_msgs/msg/TFMessage", 1}},
      {"/amcl_pose", {"geometry_msgs/msg/PoseWithCovarianceStamped", 135}}},
     1778234353382747000ull,
     1778234450738043000ull},
    // metadata.yaml: 518 messages from 1714741164111822142 ns, duration 51684723334 ns.
    {"rosbag2_tf_example",
     {{"/tf_static", {"tf2_msgs/msg/TFMessage", 1}}, {"/tf", {"tf2_msgs/msg/TFMessage", 517}}},
     1714741164111822142ull,
     1714741164111822142ull + 51684723334ull},
    {"rosbag2_tf_example/tf_example.db3",
     {{"/tf_static", {"tf2_msgs/msg/TFMessage", 1}}, {"/tf", {"tf2_msgs/msg/TFMessage", 517}}},
     1714741164111822142ull,
     1714741164111822142ull + 51684723334ull},
};

std::string recordings() { return std::string(FUSE_SHARED_DATA) + "/recordings"; }

#define SKIP_WITHOUT_DATA(path) \
  if (!fs::exists(path)) GTEST_SKIP() << "shared data not found at " << (path) << " (set -DFUSE_SHARED_DATA=...)";

class Rosbag2Real : public ::testing::TestWithParam<Expect> {};

TEST_P(Rosbag2Real, TopicsTypesCountsAndTimeRangeByReadingEveryMessage) {
  const Expect& e = GetParam();
  const std::string path = recordings() + "/" + e.path;
  SKIP_WITHOUT_DATA(path);
  auto bag = open_bag(path);
  ASSERT_EQ(bag->topics().size(), e.topics.size());
  for (const auto& t : bag->topics()) {
    ASSERT_TRUE(e.topics.count(t.name)) << t.name;
    EXPECT_EQ(t.type, e.topics.at(t.name).first);
    EXPECT_EQ(t.message_count, e.topics.at(t.name).second) << t.name;
    EXPECT_EQ(t.serialization, Serialization::kCdr);
  }
  EXPECT_EQ(bag->start_time_ns(), e.start_ns);
  EXPECT_EQ(bag->end_time_ns(), e.end_ns);

  bag->start();
  BagMessage m;
  std::map<std::string, std::uint64_t> counts;
  std::uint64_t first = 0, last = 0, n = 0;
  while (bag->next(m)) {
    ASSERT_LT(m.topic, bag->topics().size());
    if (n++ == 0) first = m.time_ns;
    ASSERT_GE(m.time_ns, last);
    last = m.time_ns;
    ++counts[bag->topics()[m.topic].name];
    // CDR encapsulation header: 0x00 0x01 (little-endian plain CDR), options 0x00 0x00.
    ASSERT_GE(m.data.size(), 4u);
    EXPECT_EQ(m.data[0], 0);
    EXPECT_EQ(m.data[1], 1);
  }
  EXPECT_EQ(first, e.start_ns);
  EXPECT_EQ(last, e.end_ns);
  for (const auto& [name, te] : e.topics) EXPECT_EQ(counts[name], te.second) << name;

  // A topic filter returns only that topic.
  bag->start({"/tf_static"});
  n = 0;
  while (bag->next(m)) {
    EXPECT_EQ(bag->topics()[m.topic].name, "/tf_static");
    ++n;
  }
  EXPECT_EQ(n, 1u);
}

INSTANTIATE_TEST_SUITE_P(Recordings, Rosbag2Real, ::testing::ValuesIn(kInputs), [](const auto& info) {
  std::string s = info.param.path;
  for (auto& ch : s) if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return s;
});

TEST(Rosbag2, SameDataAsRos1BagHasTheSameMessageTimes) {
  const std::string ros1 = recordings() + "/tf_example.bag", ros2 = recordings() + "/rosbag2_tf_example";
  SKIP_WITHOUT_DATA(ros1);
  auto times = [](const std::string& p) {
    auto bag = open_bag(p);
    bag->start();
    BagMessage m;
    std::vector<std::pair<std::string, std::uint64_t>> out;
    while (bag->next(m)) out.emplace_back(bag->topics()[m.topic].name, m.time_ns);
    return out;
  };
  const auto a = times(ros1), b = times(ros2);
  EXPECT_EQ(a.size(), 518u);
  EXPECT_EQ(a, b);
  EXPECT_EQ(ros1_type_name("tf2_msgs/msg/TFMessage"), "tf2_msgs/TFMessage");
  EXPECT_EQ(ros1_type_name("sensor_msgs/Imu"), "sensor_msgs/Imu");
}

std::string error_of(const std::string& path) {
  try {
    auto bag = open_bag(path);
    bag->start();
    BagMessage m;
    while (bag->next(m)) {
    }
    return "";
  } catch (const io::InputError& e) {
    return e.what();
  }
}

void write_text(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

TEST(Rosbag2, BadInputGivesAClearError) {
  const std::string src = recordings() + "/rosbag2_tf_example";
  SKIP_WITHOUT_DATA(src);
  const fs::path dir = fs::path(::testing::TempDir()) / "rosbag2_bad";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ifstream in(src + "/metadata.yaml");
  const std::string meta((std::istreambuf_iterator<char>(in)), {});

  EXPECT_NE(error_of(dir.string()).find("no metadata.yaml"), std::string::npos);
  write_text((dir / "metadata.yaml").string(), meta);
  EXPECT_NE(error_of(dir.string()).find("storage file tf_example.db3 is missing"), std::string::npos) << error_of(dir.string());
  write_text((dir / "tf_example.db3").string(), "this is not an sqlite database, just text of some length........");
  EXPECT_NE(error_of(dir.string()).find("tf_example.db3"), std::string::npos) << error_of(dir.string());

  std::string compressed = meta;
  compressed.replace(compressed.find("compression_format: ''"), 22, "compression_format: zstd");
  write_text((dir / "metadata.yaml").string(), compressed);
  EXPECT_NE(error_of(dir.string()).find("compressed rosbag2"), std::string::npos);
  write_text((dir / "metadata.yaml").string(), "rosbag2_bagfile_information: {version: 8}\n");
  EXPECT_NE(error_of(dir.string()).find("missing 'storage_identifier'"), std::string::npos);
  write_text((dir / "metadata.yaml").string(), "rosbag2_bagfile_information: [\n");
  EXPECT_NE(error_of(dir.string()).find("not valid YAML"), std::string::npos);

  // A cut-off sqlite file (half of it).
  std::ifstream db(src + "/tf_example.db3", std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(db)), {});
  write_text((dir / "metadata.yaml").string(), meta);
  std::ofstream((dir / "tf_example.db3").string(), std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  EXPECT_FALSE(error_of(dir.string()).empty());
  EXPECT_NE(error_of((dir / "x.txt").string()).find("no such file"), std::string::npos);
  write_text((dir / "x.txt").string(), "x");
  EXPECT_NE(error_of((dir / "x.txt").string()).find("unknown bag kind"), std::string::npos);
  fs::remove_all(dir);
}

TEST(Rosbag2, TruncatedMcapGivesAnErrorAfterTheCompleteMessages) {
  const std::string src = recordings() + "/nav2_turtlebot.mcap";
  SKIP_WITHOUT_DATA(src);
  std::ifstream in(src, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), {});
  for (double f : {0.0, 0.01, 0.5, 0.99}) {
    const std::string out = ::testing::TempDir() + "/cut.mcap";
    std::ofstream(out, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(f * static_cast<double>(bytes.size())));
    EXPECT_NE(error_of(out).find("cut.mcap"), std::string::npos) << f;
  }
}

}  // namespace
}  // namespace fuse::rosbag

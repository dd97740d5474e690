// Publish/subscribe on each vendor: raw bytes, typed samples with several endpoints per topic,
// transient-local late joiners (also keyed, per instance) and malformed samples.
#include "test_util.hpp"

namespace fuse::transport::test {
namespace {

class PubSub : public ::testing::TestWithParam<std::string> {
 protected:
  /// Domain ids 11..15, 17, 18 (fastdds) and 21..25, 27, 28 (cyclonedds); 16 and 26 are CrossProcess'.
  int domain(int offset) const { return (GetParam() == "fastdds" ? 11 : 21) + offset; }
  TransportConfig cfg(int offset) const { return config(GetParam(), domain(offset)); }
};

TEST_P(PubSub, RawBytesArriveUnchanged) {
  auto a = make_participant(cfg(0), "raw-writer");
  auto b = make_participant(cfg(0), "raw-reader");
  EXPECT_EQ(a->vendor(), GetParam());
  std::mutex mutex;
  std::vector<Bytes> got;
  const TypeSupport type = type_support<fuse_msgs::Health>();
  auto reader = b->create_reader(topics::kHealth, type, topic_qos(topics::kHealth),
                                 [&](const std::uint8_t* data, std::size_t size) {
                                   std::lock_guard<std::mutex> lock(mutex);
                                   got.emplace_back(data, data + size);
                                 });
  auto writer = a->create_writer(topics::kHealth, type, topic_qos(topics::kHealth));
  ASSERT_TRUE(wait_until([&] { return writer->matched_readers() == 1 && reader->matched_writers() == 1; }));
  const Bytes sample = serialize(make_health(4));
  EXPECT_TRUE(writer->write(sample));
  EXPECT_FALSE(writer->write(Bytes{0x00, 0x01}));  // no room for the encapsulation header
  ASSERT_TRUE(wait_until([&] {
    std::lock_guard<std::mutex> lock(mutex);
    return !got.empty();
  }));
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0], sample);
}

TEST_P(PubSub, SeveralWritersAndReadersOnOneTopic) {
  auto a = make_participant(cfg(1), "a");
  auto b = make_participant(cfg(1), "b");
  Inbox<fuse_msgs::LidarScan> in_a, in_b1, in_b2;
  // A reads what it writes itself (same participant), B has two readers.
  Subscriber<fuse_msgs::LidarScan> sub_a(*a, topics::kLidarScan, std::ref(in_a));
  Subscriber<fuse_msgs::LidarScan> sub_b1(*b, topics::kLidarScan, std::ref(in_b1));
  Subscriber<fuse_msgs::LidarScan> sub_b2(*b, topics::kLidarScan, std::ref(in_b2));
  Publisher<fuse_msgs::LidarScan> pub1(*a, topics::kLidarScan);
  Publisher<fuse_msgs::LidarScan> pub2(*b, topics::kLidarScan);
  ASSERT_TRUE(wait_until([&] {
    return pub1.matched() == 3 && pub2.matched() == 3 && sub_a.matched() == 2 && sub_b1.matched() == 2 &&
           sub_b2.matched() == 2;
  }));
  EXPECT_TRUE(pub1.publish(make_scan(1)));
  EXPECT_TRUE(pub2.publish(make_scan(2)));
  for (auto* inbox : {&in_a, &in_b1, &in_b2}) {
    ASSERT_TRUE(inbox->wait_for(2));
    std::set<std::uint64_t> sequences;
    for (const auto& scan : inbox->messages()) sequences.insert(scan.sequence_number());
    EXPECT_EQ(sequences, (std::set<std::uint64_t>{8, 9}));
  }
  EXPECT_EQ(sub_a.received() + sub_b1.received() + sub_b2.received(), 6u);
}

TEST_P(PubSub, TransientLocalLateJoinerGetsTheHistory) {
  auto a = make_participant(cfg(2), "early");
  Publisher<fuse_msgs::ImuSample> imu(*a, topics::kImu);
  Publisher<fuse_msgs::StateEstimate> corrected(*a, topics::kCorrected);
  for (int i = 0; i < 50; ++i) EXPECT_TRUE(imu.publish(make_imu(i)));
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(corrected.publish(make_state(i)));

  auto b = make_participant(cfg(2), "late");
  Inbox<fuse_msgs::ImuSample> imu_in;
  Inbox<fuse_msgs::StateEstimate> corrected_in;
  Subscriber<fuse_msgs::ImuSample> imu_sub(*b, topics::kImu, std::ref(imu_in));
  Subscriber<fuse_msgs::StateEstimate> corrected_sub(*b, topics::kCorrected, std::ref(corrected_in));
  ASSERT_TRUE(imu_in.wait_for(50));
  ASSERT_TRUE(corrected_in.wait_for(1));
  std::this_thread::sleep_for(200ms);  // nothing more may arrive
  const auto imus = imu_in.messages();
  ASSERT_EQ(imus.size(), 50u);  // depth 2000: all of them, in order
  for (int i = 0; i < 50; ++i) EXPECT_EQ(imus[i].sequence_number(), static_cast<std::uint64_t>(i + 1));
  const auto states = corrected_in.messages();
  ASSERT_EQ(states.size(), 1u);  // depth 1: only the latest
  EXPECT_EQ(serialize(states[0]), serialize(make_state(2)));
}

TEST_P(PubSub, KeyedLateJoinerGetsTheLatestOfEachKey) {
  auto a = make_participant(cfg(3), "map-server");
  Publisher<fuse_msgs::MapChunk> chunks(*a, topics::kMapChunk);
  const std::uint64_t k1 = 0x0000'0001'0000'0002ull, k2 = 0xFFFF'0000'0000'0001ull;
  for (std::uint64_t revision = 1; revision <= 3; ++revision) {
    EXPECT_TRUE(chunks.publish(make_chunk(k1, revision)));
    EXPECT_TRUE(chunks.publish(make_chunk(k2, revision)));
  }
  EXPECT_TRUE(chunks.publish(make_chunk(k1, 4)));

  auto b = make_participant(cfg(3), "replica");
  Inbox<fuse_msgs::MapChunk> in;
  Subscriber<fuse_msgs::MapChunk> sub(*b, topics::kMapChunk, std::ref(in));
  ASSERT_TRUE(in.wait_for(2));
  std::this_thread::sleep_for(200ms);
  std::map<std::uint64_t, std::uint64_t> latest;
  for (const auto& c : in.messages()) latest[c.key()] = std::max(latest[c.key()], c.revision());
  EXPECT_EQ(in.size(), 2u);
  EXPECT_EQ(latest, (std::map<std::uint64_t, std::uint64_t>{{k1, 4}, {k2, 3}}));
}

TEST_P(PubSub, MalformedSampleIsCountedNotDelivered) {
  auto a = make_participant(cfg(4), "garbage");
  auto b = make_participant(cfg(4), "victim");
  Inbox<fuse_msgs::ImuSample> in;
  std::mutex mutex;
  std::vector<std::string> reasons;
  Subscriber<fuse_msgs::ImuSample> sub(*b, topics::kImu, std::ref(in), [&](const std::string& why) {
    std::lock_guard<std::mutex> lock(mutex);
    reasons.push_back(why);
  });
  auto raw = a->create_writer(topics::kImu, type_support<fuse_msgs::ImuSample>(), topic_qos(topics::kImu));
  ASSERT_TRUE(wait_until([&] { return raw->matched_readers() == 1 && sub.matched() == 1; }));
  EXPECT_TRUE(raw->write(Bytes{0x00, 0x01, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0x12}));
  EXPECT_TRUE(raw->write(serialize(make_imu(6))));
  ASSERT_TRUE(in.wait_for(1));
  ASSERT_TRUE(wait_until([&] { return sub.malformed() == 1; }));
  EXPECT_EQ(sub.received(), 1u);
  EXPECT_EQ(in.messages()[0].sequence_number(), 7u);
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_EQ(reasons.size(), 1u);
  EXPECT_NE(reasons[0].find("CDR decoding failed"), std::string::npos) << reasons[0];
}

TEST_P(PubSub, WaitForAcknowledgmentsCoversEverythingWrittenBeforeTheWriterGoes) {
  // A writer about to exit waits until its reader has every sample; then everything arrives
  // although the writer (and its history, which repairs would need) is gone at once.
  constexpr int kSamples = 500;
  auto b = make_participant(cfg(6), "reader");
  Inbox<fuse_msgs::ImuSample> in;
  Subscriber<fuse_msgs::ImuSample> sub(*b, topics::kImu, std::ref(in));
  {
    auto a = make_participant(cfg(6), "exiting-writer");
    Publisher<fuse_msgs::ImuSample> imu(*a, topics::kImu);
    EXPECT_TRUE(imu.wait_for_acknowledgments(100ms)) << "nothing written, nothing to wait for";
    ASSERT_TRUE(wait_until([&] { return imu.matched() == 1 && sub.matched() == 1; }));
    for (int i = 0; i < kSamples; ++i) ASSERT_TRUE(imu.publish(make_imu(i)));
    EXPECT_TRUE(imu.wait_for_acknowledgments(10s));
  }
  ASSERT_TRUE(in.wait_for(kSamples, 5s)) << in.size() << " of " << kSamples;
  const auto got = in.messages();
  for (int i = 0; i < kSamples; ++i) EXPECT_EQ(got[i].sequence_number(), static_cast<std::uint64_t>(i + 1));
}

TEST_P(PubSub, TwoSystemsOnOneDomainDoNotSeeEachOther) {
  // transport.system_name: A and B are two systems on one domain, A2 is a second process of A.
  TransportConfig a_cfg = cfg(7), b_cfg = cfg(7);
  a_cfg.system_name = "vehicle-a";
  b_cfg.system_name = "vehicle-b";
  auto a = make_participant(a_cfg, "a");
  auto a2 = make_participant(a_cfg, "a2");
  auto b = make_participant(b_cfg, "b");
  auto unnamed = make_participant(cfg(7), "unnamed");  // the default partition
  Inbox<fuse_msgs::ImuSample> in_a2, in_b, in_unnamed;
  Subscriber<fuse_msgs::ImuSample> sub_a2(*a2, topics::kImu, std::ref(in_a2));
  Subscriber<fuse_msgs::ImuSample> sub_b(*b, topics::kImu, std::ref(in_b));
  Subscriber<fuse_msgs::ImuSample> sub_unnamed(*unnamed, topics::kImu, std::ref(in_unnamed));
  Publisher<fuse_msgs::ImuSample> pub_a(*a, topics::kImu);
  Publisher<fuse_msgs::ImuSample> pub_b(*b, topics::kImu);
  Publisher<fuse_msgs::ImuSample> pub_unnamed(*unnamed, topics::kImu);
  // Every participant has been discovered once each partition's own pair has matched.
  ASSERT_TRUE(wait_until([&] {
    return pub_a.matched() >= 1 && pub_b.matched() >= 1 && pub_unnamed.matched() >= 1 && sub_a2.matched() >= 1;
  }));
  EXPECT_TRUE(pub_a.publish(make_imu(1)));
  EXPECT_TRUE(pub_b.publish(make_imu(2)));
  ASSERT_TRUE(in_a2.wait_for(1));
  ASSERT_TRUE(in_b.wait_for(1));
  EXPECT_EQ(in_a2.messages().front().t(), make_imu(1).t());
  EXPECT_EQ(in_b.messages().front().t(), make_imu(2).t());
  EXPECT_EQ(pub_a.matched(), 1u) << "A's IMU is matched by A only";
  EXPECT_EQ(pub_b.matched(), 1u);
  EXPECT_EQ(sub_unnamed.matched(), 1u) << "the default partition hears only its own";
  EXPECT_EQ(in_a2.size() + in_b.size(), 2u);
  EXPECT_EQ(in_unnamed.size(), 0u);
}

INSTANTIATE_TEST_SUITE_P(Vendors, PubSub, ::testing::ValuesIn(vendors()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace fuse::transport::test

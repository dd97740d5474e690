// TransportConfig::load validation and the QoS table (no DDS involved).
#include "test_util.hpp"

namespace fuse::transport::test {
namespace {

TransportConfig load(const std::string& yaml) {
  ConfigNode node = ConfigNode::from_string(yaml);
  TransportConfig c;
  c.load(node);
  return c;
}

TEST(TransportConfig, DefaultsAndValidValues) {
  const TransportConfig d = load("{}");
  EXPECT_EQ(d.vendor, "fastdds");
  EXPECT_EQ(d.domain_id, 0);
  EXPECT_TRUE(d.loopback_only);
  EXPECT_EQ(d.max_participants, 32);
  EXPECT_EQ(d.socket_buffer_bytes, 4u << 20);
  EXPECT_FALSE(d.shared_memory);
  const TransportConfig c = load(
      "vendor: cyclonedds\ndomain_id: 101\nloopback_only: false\nmax_participants: 120\n"
      "socket_buffer_bytes: 65536\nshared_memory: true\n");
  EXPECT_EQ(c.vendor, "cyclonedds");
  EXPECT_EQ(c.domain_id, 101);
  EXPECT_FALSE(c.loopback_only);
  EXPECT_EQ(c.max_participants, 120);
  EXPECT_EQ(c.socket_buffer_bytes, 65536u);
  EXPECT_TRUE(c.shared_memory);
}

TEST(TransportConfig, RefusesBadValuesAndUnknownKeys) {
  for (const char* yaml : {"vendor: opendds", "domain_id: -1", "domain_id: 102", "max_participants: 3",
                           "max_participants: 121", "socket_buffer_bytes: 1000", "socket_buffer_bytes: 1e12",
                           "vendor: [fastdds]", "multicast: true"}) {
    EXPECT_THROW(load(yaml), ConfigError) << yaml;
  }
}

TEST(TransportConfig, InterfacesPeersAndSecurityAreChecked) {
  const TransportConfig c = load(
      "loopback_only: false\ninterfaces: [10.77.0.1]\npeers: [10.77.0.1, 10.77.0.2]\n"
      "security: {enabled: true, keystore: /etc/fuse-slam/keystore, identity: planner-2}\n");
  EXPECT_EQ(c.interfaces, std::vector<std::string>{"10.77.0.1"});
  EXPECT_EQ(c.peers.size(), 2u);
  EXPECT_TRUE(c.security.enabled);
  EXPECT_EQ(c.security.identity, "planner-2");
  const std::vector<std::pair<std::string, std::string>> bad{
      {"peers: [10.77.0.2]", "peers"},  // loopback_only (the default) has no peers
      {"loopback_only: false\npeers: [vehicle-2]", "peers"},
      {"loopback_only: false\ninterfaces: [10.77.0.300]", "interfaces"},
      {"loopback_only: false\ninterfaces: [\"::1\"]", "interfaces"},
      {"security: {enabled: true}", "security.keystore"},
      {"security: {identity: ../key}", "security.identity"},
      {"security: {enabled: true, keystore: k, password: x}", "security.password"}};
  for (const auto& [yaml, key] : bad) {
    try {
      load(yaml);
      ADD_FAILURE() << "accepted: " << yaml;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << yaml << ": " << e.what();
    }
  }
}

TEST(TransportConfig, MakeParticipantRefusesAnUnknownVendor) {
  TransportConfig c;
  c.vendor = "opendds";
  EXPECT_THROW(make_participant(c, "x"), std::runtime_error);
}

TEST(TopicQosTable, EveryTopicAndRpcHasItsQos) {
  const TopicQos& imu = topic_qos(topics::kImu);
  EXPECT_EQ(imu.reliability, Reliability::kReliable);
  EXPECT_EQ(imu.durability, Durability::kTransientLocal);
  EXPECT_EQ(imu.depth, 2000);
  EXPECT_EQ(topic_qos(topics::kOdometry).reliability, Reliability::kBestEffort);
  EXPECT_EQ(topic_qos(topics::kLidarScan).reliability, Reliability::kReliable);
  EXPECT_EQ(topic_qos(topics::kMapChunk).depth, 1);
  EXPECT_EQ(topic_qos(topics::kMapChunk).durability, Durability::kTransientLocal);
  for (const char* t : {topics::kImu, topics::kLidarScan, topics::kOdometry, topics::kCorrected, topics::kCorrection,
                        topics::kObservation, topics::kMapChunk, topics::kMapStatus, topics::kHealth}) {
    EXPECT_GT(topic_qos(t).depth, 0) << t;
  }
  for (const char* s : {services::kQuery, services::kHistory, services::kMapControl}) {
    // The RPC layer re-sends and de-duplicates: the latency-critical calls skip DDS reliability.
    const Reliability expected = s == services::kMapControl ? Reliability::kReliable : Reliability::kBestEffort;
    for (const std::string& t : {request_topic(s), reply_topic(s)}) {
      EXPECT_EQ(topic_qos(t).reliability, expected) << t;
      EXPECT_EQ(topic_qos(t).durability, Durability::kVolatile) << t;
      EXPECT_EQ(topic_qos(t).depth, 32) << t;
    }
  }
  EXPECT_THROW(topic_qos("no/such/topic"), std::invalid_argument);
  EXPECT_THROW(topic_qos("rpc/unknown/request"), std::invalid_argument);
}

TEST(TypeSupport, NamesKeysAndSizes) {
  EXPECT_EQ(type_support<fuse_msgs::MapChunk>().name, "fuse_msgs::MapChunk");
  EXPECT_TRUE(type_support<fuse_msgs::MapChunk>().keyed);
  EXPECT_FALSE(type_support<fuse_msgs::ImuSample>().keyed);
  EXPECT_GT(type_support<fuse_msgs::MapChunk>().max_serialized_size, 12u << 20);
  EXPECT_GT(type_support<fuse_msgs::LidarScan>().max_serialized_size, 6u << 20);
}

}  // namespace
}  // namespace fuse::transport::test

// Fast DDS <-> Cyclone DDS: every wire type both ways (compared byte for byte after
// re-serialising), a ~1 MiB scan both ways, malformed samples across vendors, and the typed
// request/reply with client and server on different vendors.
#include "test_util.hpp"

namespace fuse::transport::test {
namespace {

/// One type's publisher on the sending vendor and subscriber on the receiving one.
struct Check {
  virtual ~Check() = default;
  virtual bool matched() const = 0;
  virtual void publish() = 0;
  virtual std::size_t received() const = 0;
  virtual void verify() const = 0;
};

template <class T>
struct TypedCheck : Check {
  TypedCheck(Participant& from, Participant& to, const std::string& topic, int seed)
      : topic(topic),
        sent(Sample<T>::make(seed)),
        subscriber(to, topic, std::ref(inbox)),
        publisher(from, topic) {}
  bool matched() const override { return publisher.matched() > 0 && subscriber.matched() > 0; }
  void publish() override { EXPECT_TRUE(publisher.publish(sent)) << topic; }
  std::size_t received() const override { return inbox.size(); }
  void verify() const override {
    const auto messages = inbox.messages();
    ASSERT_FALSE(messages.empty()) << MsgName<T>::value << " on " << topic;
    for (const auto& m : messages) EXPECT_EQ(serialize(m), serialize(sent)) << MsgName<T>::value << " on " << topic;
  }
  std::string topic;
  T sent;
  Inbox<T> inbox;
  Subscriber<T> subscriber;
  Publisher<T> publisher;
};

void every_type(const std::string& from_vendor, const std::string& to_vendor, int domain) {
  auto from = make_participant(config(from_vendor, domain), "sender");
  auto to = make_participant(config(to_vendor, domain), "receiver");
  std::vector<std::unique_ptr<Check>> checks;
  int seed = 1;
  for_each_type([&](auto tag) {
    using T = decltype(tag);
    checks.push_back(std::make_unique<TypedCheck<T>>(*from, *to, Sample<T>::topic_name(), seed++));
  });
  // Best effort too (published until one arrives).
  checks.push_back(std::make_unique<TypedCheck<fuse_msgs::StateEstimate>>(*from, *to, topics::kOdometry, seed++));
  ASSERT_TRUE(wait_until([&] {
    for (const auto& c : checks)
      if (!c->matched()) return false;
    return true;
  })) << "not every topic matched between " << from_vendor << " and " << to_vendor;

  std::vector<std::chrono::steady_clock::time_point> last(checks.size());
  const bool all = wait_until([&] {
    bool done = true;
    for (std::size_t i = 0; i < checks.size(); ++i) {
      if (checks[i]->received() > 0) continue;
      done = false;
      if (std::chrono::steady_clock::now() - last[i] > 500ms) {
        checks[i]->publish();
        last[i] = std::chrono::steady_clock::now();
      }
    }
    return done;
  });
  EXPECT_TRUE(all) << "not every type arrived";
  for (const auto& c : checks) c->verify();
}

TEST(CrossVendor, EveryTypeFastddsToCyclone) { every_type("fastdds", "cyclonedds", 30); }
TEST(CrossVendor, EveryTypeCycloneToFastdds) { every_type("cyclonedds", "fastdds", 31); }

void large_scans(const std::string& from_vendor, const std::string& to_vendor, int domain) {
  auto from = make_participant(config(from_vendor, domain), "lidar");
  auto to = make_participant(config(to_vendor, domain), "estimator");
  Inbox<fuse_msgs::LidarScan> in;
  Subscriber<fuse_msgs::LidarScan> sub(*to, topics::kLidarScan, std::ref(in));
  Publisher<fuse_msgs::LidarScan> pub(*from, topics::kLidarScan);
  ASSERT_TRUE(wait_until([&] { return pub.matched() == 1 && sub.matched() == 1; }));
  std::vector<Bytes> sent;
  for (int i = 0; i < 3; ++i) {
    const auto scan = make_scan(i, 44000);  // 44000 points x 24 bytes: ~1 MiB
    sent.push_back(serialize(scan));
    ASSERT_GT(sent.back().size(), 1000000u);
    EXPECT_TRUE(pub.publish(scan));
  }
  ASSERT_TRUE(in.wait_for(3));
  const auto got = in.messages();
  ASSERT_EQ(got.size(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(serialize(got[i]) == sent[i]) << "scan " << i;
}

TEST(CrossVendor, MebibyteScansFastddsToCyclone) { large_scans("fastdds", "cyclonedds", 32); }
TEST(CrossVendor, MebibyteScansCycloneToFastdds) { large_scans("cyclonedds", "fastdds", 33); }

using QueryServer = RpcServer<fuse_msgs::QueryRequest, fuse_msgs::QueryReply>;
using QueryClient = RpcClient<fuse_msgs::QueryRequest, fuse_msgs::QueryReply>;

// Each server dispatch mode in turn (its own thread, and inline on the receive thread).
void rpc(const std::string& client_vendor, const std::string& server_vendor, int domain) {
  auto server_side = make_participant(config(server_vendor, domain), "fuse-state");
  auto client_side = make_participant(config(client_vendor, domain), "fuse-query");
  for (const Dispatch dispatch : {Dispatch::kWorker, Dispatch::kInline}) {
    SCOPED_TRACE(dispatch == Dispatch::kWorker ? "worker dispatch" : "inline dispatch");
    QueryServer server(
        *server_side, services::kQuery,
        [](const fuse_msgs::QueryRequest& req, fuse_msgs::QueryReply& rep) {
          if (req.t() == 13.0) throw std::runtime_error("unlucky time");
          if (req.t() < 0.0) {
            rep.error(fuse_msgs::RPC_BAD_REQUEST);
            rep.error_message("negative time");
            return;
          }
          rep.estimate(make_state(7));
          rep.estimate().t(req.t());
        },
        dispatch);
    QueryClient client(*client_side, services::kQuery);
    ASSERT_TRUE(client.wait_for_server(10s));

    fuse_msgs::QueryRequest req;
    req.t(42.5);
    auto result = client.call(req, 5s);
    ASSERT_TRUE(result.ok()) << result.message;
    EXPECT_EQ(result.reply.header().client_id(), client.client_id());
    fuse_msgs::StateEstimate expected = make_state(7);
    expected.t(42.5);
    EXPECT_EQ(serialize(result.reply.estimate()), serialize(expected));

    req.t(-1.0);
    result = client.call(req, 5s);
    EXPECT_EQ(result.status, fuse_msgs::RPC_BAD_REQUEST);
    EXPECT_EQ(result.message, "negative time");

    req.t(13.0);
    result = client.call(req, 5s);
    EXPECT_EQ(result.status, fuse_msgs::RPC_INTERNAL_ERROR);
    EXPECT_EQ(result.message, "unlucky time");
    EXPECT_EQ(server.handled(), 3u);
    EXPECT_EQ(server.malformed(), 0u);
  }
}

TEST(CrossVendor, RpcFastddsClientCycloneServer) { rpc("fastdds", "cyclonedds", 34); }
TEST(CrossVendor, RpcCycloneClientFastddsServer) { rpc("cyclonedds", "fastdds", 35); }

TEST(CrossVendor, RpcDeadlineWithoutServerIsUnavailable) {
  for (const auto& vendor : vendors()) {
    auto p = make_participant(config(vendor, 36), "lonely-client");
    QueryClient client(*p, services::kQuery);
    const auto start = std::chrono::steady_clock::now();
    const auto result = client.call(fuse_msgs::QueryRequest{}, 300ms);
    const auto elapsed = std::chrono::steady_clock::now() - start;
    EXPECT_EQ(result.status, fuse_msgs::RPC_UNAVAILABLE) << vendor;
    EXPECT_FALSE(result.ok());
    EXPECT_FALSE(result.message.empty());
    EXPECT_GE(elapsed, 300ms) << vendor;
    EXPECT_LT(elapsed, 2s) << vendor;
  }
}

TEST(CrossVendor, OneSystemSpansBothVendorsAndOnlyIt) {
  // transport.system_name is a DDS partition: both vendors' processes of one system match, a
  // second system on the same domain matches neither.
  TransportConfig fast_cfg = config("fastdds", 19), cyclone_cfg = config("cyclonedds", 19),
                  other_cfg = config("cyclonedds", 19);
  fast_cfg.system_name = cyclone_cfg.system_name = "rig";
  other_cfg.system_name = "rig-2";
  auto fast = make_participant(fast_cfg, "fast");
  auto cyclone = make_participant(cyclone_cfg, "cyclone");
  auto other = make_participant(other_cfg, "other");
  Inbox<fuse_msgs::ImuSample> in_cyclone, in_other;
  Subscriber<fuse_msgs::ImuSample> sub_cyclone(*cyclone, topics::kImu, std::ref(in_cyclone));
  Subscriber<fuse_msgs::ImuSample> sub_other(*other, topics::kImu, std::ref(in_other));
  Publisher<fuse_msgs::ImuSample> pub_fast(*fast, topics::kImu);
  Publisher<fuse_msgs::ImuSample> pub_other(*other, topics::kImu);  // other's own pair: discovery done
  ASSERT_TRUE(wait_until([&] { return pub_fast.matched() >= 1 && pub_other.matched() >= 1; }));
  EXPECT_TRUE(pub_fast.publish(make_imu(3)));
  ASSERT_TRUE(in_cyclone.wait_for(1));
  EXPECT_EQ(pub_fast.matched(), 1u);
  EXPECT_EQ(sub_other.matched(), 1u) << "only its own system's writer";
  EXPECT_EQ(in_other.size(), 0u);
}

TEST(CrossVendor, MalformedSamplesAreCountedOnBothSides) {
  auto fast = make_participant(config("fastdds", 37), "fast");
  auto cyclone = make_participant(config("cyclonedds", 37), "cyclone");
  // The IMU topic keeps 2000 samples: both garbage samples may arrive at once (a depth-1 reader
  // would legitimately keep only the newer one).
  Inbox<fuse_msgs::ImuSample> fast_in, cyclone_in;
  Subscriber<fuse_msgs::ImuSample> fast_sub(*fast, topics::kImu, std::ref(fast_in));
  Subscriber<fuse_msgs::ImuSample> cyclone_sub(*cyclone, topics::kImu, std::ref(cyclone_in));
  const TypeSupport type = type_support<fuse_msgs::ImuSample>();
  auto fast_raw = fast->create_writer(topics::kImu, type, topic_qos(topics::kImu));
  auto cyclone_raw = cyclone->create_writer(topics::kImu, type, topic_qos(topics::kImu));
  // Every reader matches both writers (its own participant's included).
  ASSERT_TRUE(wait_until([&] {
    return fast_raw->matched_readers() == 2 && cyclone_raw->matched_readers() == 2 && fast_sub.matched() == 2 &&
           cyclone_sub.matched() == 2;
  }));
  const Bytes garbage{0x00, 0x01, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0xFF, 0x12};  // a double cut short
  EXPECT_TRUE(fast_raw->write(garbage));
  EXPECT_TRUE(cyclone_raw->write(garbage));
  EXPECT_TRUE(wait_until([&] { return fast_sub.malformed() == 2 && cyclone_sub.malformed() == 2; }))
      << "fastdds reader counted " << fast_sub.malformed() << ", cyclonedds reader " << cyclone_sub.malformed();
  EXPECT_TRUE(fast_raw->write(serialize(make_imu(1))));
  EXPECT_TRUE(fast_in.wait_for(1));
  EXPECT_TRUE(cyclone_in.wait_for(1));
  EXPECT_EQ(fast_sub.received(), 1u);
  EXPECT_EQ(cyclone_sub.received(), 1u);
}

}  // namespace
}  // namespace fuse::transport::test

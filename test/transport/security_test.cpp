// DDS Security on each vendor, with keystores made by fuse-keystore: authorised identities
// talk; a process without keys, one with another CA's certificate, and one whose grant does not
// cover a topic are refused or never matched. Domain ids 1..4 (fastdds), 5..8 (cyclonedds).
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "fuse/transport/security.hpp"
#include "test_util.hpp"


namespace fuse::transport::test {
namespace {

namespace fs = std::filesystem;

/// A keystore made by the fuse-keystore binary in a fresh temporary directory.
class Keystore {
 public:
  explicit Keystore(const std::string& tag, const std::string& system = "") {
    std::string pattern = (fs::temp_directory_path() / ("fuse-keystore-test-" + tag + "-XXXXXX")).string();
    dir_ = ::mkdtemp(pattern.data());
    const std::string init = "init " + dir_ + "/ks" + (system.empty() ? "" : " --system " + system);
    for (const std::string& args : {init, "add-identity " + dir_ + "/ks second-planner --role planner"}) {
      if (run(args) != 0) throw std::runtime_error("fuse-keystore " + args + " failed");
    }
  }
  ~Keystore() { fs::remove_all(dir_); }
  std::string path() const { return dir_ + "/ks"; }

  static int run(const std::string& args) {
    const std::string cmd = std::string(FUSE_KEYSTORE_BIN) + " " + args + " >/dev/null 2>&1";
    const int status = std::system(cmd.c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

 private:
  std::string dir_;
};

const Keystore& keystore() {
  static Keystore k("a");
  return k;
}
const Keystore& foreign_keystore() {  // another CA: same identity names, same grants
  static Keystore k("b");
  return k;
}

TransportConfig secured(const std::string& vendor, int domain, const std::string& keystore_dir,
                        const std::string& identity = "") {
  TransportConfig c;
  c.vendor = vendor;
  c.domain_id = domain;
  c.security.enabled = true;
  c.security.keystore = keystore_dir;
  c.security.identity = identity;
  return c;
}

TransportConfig plain(const std::string& vendor, int domain) {
  TransportConfig c;
  c.vendor = vendor;
  c.domain_id = domain;
  return c;
}

class Security : public ::testing::TestWithParam<std::string> {
 protected:
  int domain(int offset) const { return (GetParam() == "fastdds" ? 1 : 5) + offset; }
  TransportConfig as(const std::string& identity, int offset) const {
    return secured(GetParam(), domain(offset), keystore().path(), identity);
  }
};

// ---- the other side: a child process (this binary, DISABLED_SecurityChild.Run) ------------
// Cyclone DDS runs one security context per domain and process, so every identity of a test is
// a process of its own, as on a vehicle. The child does one thing and writes one result line.

constexpr std::uint64_t kRogue = 1000;  ///< sequence numbers of samples nobody may accept

struct ChildResult {
  bool created = false;  ///< its endpoint was allowed
  long received = 0;     ///< samples of the system's own (not rogue) it read
  long matched = 0;      ///< most peers its endpoint matched
  int status = -1;       ///< RPC status of its call (fuse_msgs::RpcStatus)
};

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return v == nullptr ? "" : v;
}

TEST(DISABLED_SecurityChild, Run) {
  const std::string action = env("FUSE_SEC_ACTION");
  if (action.empty()) GTEST_SKIP() << "only run when spawned by a Security test";
  TransportConfig c = plain(env("FUSE_SEC_VENDOR"), std::atoi(env("FUSE_SEC_DOMAIN").c_str()));
  if (!env("FUSE_SEC_KEYSTORE").empty()) c = secured(c.vendor, c.domain_id, env("FUSE_SEC_KEYSTORE"));
  const auto seconds = std::chrono::seconds(std::atoi(env("FUSE_SEC_SECONDS").c_str()));
  ChildResult r;
  try {
    auto participant = make_participant(c, env("FUSE_SEC_IDENTITY"));
    if (action == "publish" || action == "rogue") {
      Publisher<fuse_msgs::ImuSample> pub(*participant, topics::kImu);
      r.created = true;
      const bool rogue = action == "rogue";
      // A good publisher waits for its reader and then sends 50 samples; a rogue one keeps
      // sending for the whole time.
      if (!rogue) wait_until([&] { return pub.matched() > 0; }, seconds);
      const auto end = std::chrono::steady_clock::now() + (rogue ? seconds : 1500ms);
      for (std::uint64_t i = 0; std::chrono::steady_clock::now() < end; ++i) {
        pub.publish(make_imu(static_cast<int>((rogue ? kRogue : 0) + i)));
        r.matched = std::max<long>(r.matched, static_cast<long>(pub.matched()));
        std::this_thread::sleep_for(20ms);  // the sample rate of this publisher
      }
      pub.wait_for_acknowledgments(2s);
    } else if (action == "spy") {
      Inbox<fuse_msgs::ImuSample> inbox;
      Subscriber<fuse_msgs::ImuSample> sub(*participant, topics::kImu, std::ref(inbox));
      r.created = true;
      const auto end = std::chrono::steady_clock::now() + seconds;
      while (std::chrono::steady_clock::now() < end) {
        r.matched = std::max<long>(r.matched, static_cast<long>(sub.matched()));
        std::this_thread::sleep_for(20ms);
      }
      for (const auto& m : inbox.messages()) r.received += m.sequence_number() < kRogue ? 1 : 0;  // the system's own
    } else if (action == "query" || action == "control") {
      fuse_msgs::RpcStatus status;
      if (action == "query") {
        RpcClient<fuse_msgs::QueryRequest, fuse_msgs::QueryReply> client(*participant, services::kQuery);
        r.created = true;
        fuse_msgs::QueryRequest req;
        req.t(41.0);
        status = client.call(req, seconds).status;
      } else {
        RpcClient<fuse_msgs::MapControlRequest, fuse_msgs::MapControlReply> client(*participant, services::kMapControl);
        r.created = true;
        fuse_msgs::MapControlRequest req;
        req.command(fuse_msgs::MAP_STATS);
        status = client.call(req, seconds).status;
      }
      r.status = static_cast<int>(status);
    }
  } catch (const std::exception& e) {
    std::cerr << "child " << action << ": " << e.what() << "\n";
  }
  std::ofstream(env("FUSE_SEC_RESULT")) << r.created << " " << r.received << " " << r.matched << " " << r.status << "\n";
}

/// One child process doing `action` as `identity` (keystore empty: without security).
class Child {
 public:
  Child(const std::string& vendor, int domain, const std::string& keystore, const std::string& identity,
        const std::string& action, int seconds) {
    result_file_ = (fs::temp_directory_path() / ("fuse-sec-child-" + std::to_string(::getpid()) + "-" +
                                                 std::to_string(counter()++)))
                       .string();
    pid_ = spawn_this_test("DISABLED_SecurityChild.Run",
                           {"FUSE_SEC_VENDOR=" + vendor, "FUSE_SEC_DOMAIN=" + std::to_string(domain),
                            "FUSE_SEC_KEYSTORE=" + keystore, "FUSE_SEC_IDENTITY=" + identity,
                            "FUSE_SEC_ACTION=" + action, "FUSE_SEC_SECONDS=" + std::to_string(seconds),
                            "FUSE_SEC_RESULT=" + result_file_});
  }
  ~Child() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    fs::remove(result_file_);
  }
  /// Waits for the child to finish (it ends by itself) and reads its result.
  ChildResult result() {
    ChildResult r;
    if (pid_ <= 0) {
      ADD_FAILURE() << "could not start a child process";
      return r;
    }
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
    std::ifstream in(result_file_);
    int created = 0;
    if (!(in >> created >> r.received >> r.matched >> r.status)) ADD_FAILURE() << "the child wrote no result";
    r.created = created != 0;
    return r;
  }

 private:
  static int& counter() {
    static int n = 0;
    return n;
  }
  pid_t pid_ = -1;
  std::string result_file_;
};

TEST_P(Security, OnlyAuthorisedProcessesAreHeard) {
  // This process is fuse-state: it reads IMU samples and answers queries.
  auto state = make_participant(as("", 0), "fuse-state");
  Inbox<fuse_msgs::ImuSample> inbox;
  Subscriber<fuse_msgs::ImuSample> sub(*state, topics::kImu, std::ref(inbox));
  RpcServer<fuse_msgs::QueryRequest, fuse_msgs::QueryReply> server(
      *state, services::kQuery,
      [](const fuse_msgs::QueryRequest& r, fuse_msgs::QueryReply& rep) { rep.estimate().t(r.t() + 1); });
  const std::string v = GetParam();
  const int d = domain(0);
  Child no_keys(v, d, "", "intruder", "rogue", 12);
  Child forged(v, d, foreign_keystore().path(), "fuse-ingest", "rogue", 12);  // same name, another CA
  Child spy(v, d, "", "spy", "spy", 12);
  Child ingest(v, d, keystore().path(), "fuse-ingest", "publish", 20);
  Child planner(v, d, keystore().path(), "fuse-query", "query", 20);
  Child intruder_query(v, d, "", "fuse-query", "query", 4);

  const ChildResult good = ingest.result();
  EXPECT_TRUE(good.created);
  EXPECT_GE(good.matched, 1);
  ASSERT_TRUE(inbox.wait_for(50)) << "fuse-ingest's samples did not all arrive: " << inbox.size();
  EXPECT_EQ(planner.result().status, static_cast<int>(fuse_msgs::RPC_OK)) << "the planner's query was not answered";
  // Each may create its endpoint locally, but nobody of the system matches it. (The processes
  // without keys do match each other: the spy reads the intruder's samples, never the system's.)
  EXPECT_TRUE(no_keys.result().created);
  const ChildResult f = forged.result();
  EXPECT_TRUE(f.created);
  EXPECT_EQ(f.matched, 0) << "a certificate of another CA was matched";
  EXPECT_EQ(spy.result().received, 0) << "a process without keys read the system's IMU samples";
  EXPECT_EQ(intruder_query.result().status, static_cast<int>(fuse_msgs::RPC_UNAVAILABLE));
  for (const auto& m : inbox.messages()) EXPECT_LT(m.sequence_number(), kRogue) << "a rogue sample arrived";
}

TEST_P(Security, OnlyTheOperatorMayCallMapControl) {
  auto map = make_participant(as("", 1), "fuse-map");
  std::atomic<int> handled{0};
  std::string caller;  // written in the handler, read after the children are done
  RpcServer<fuse_msgs::MapControlRequest, fuse_msgs::MapControlReply>* self = nullptr;
  RpcServer<fuse_msgs::MapControlRequest, fuse_msgs::MapControlReply> server(
      *map, services::kMapControl, [&](const fuse_msgs::MapControlRequest&, fuse_msgs::MapControlReply&) {
        ++handled;
        caller = self->caller();
      });
  self = &server;
  server.track_callers();
  const std::string v = GetParam();
  const int d = domain(1);
  Child no_keys(v, d, "", "fuse-map-ctl", "control", 4);
  Child planner(v, d, keystore().path(), "fuse-query", "control", 4);
  Child foreign(v, d, foreign_keystore().path(), "fuse-map-ctl", "control", 4);
  Child op(v, d, keystore().path(), "fuse-map-ctl", "control", 20);
  EXPECT_EQ(op.result().status, static_cast<int>(fuse_msgs::RPC_OK));
  EXPECT_EQ(no_keys.result().status, static_cast<int>(fuse_msgs::RPC_UNAVAILABLE));
  EXPECT_FALSE(planner.result().created) << "the planner's grant let it create a map control client";
  EXPECT_EQ(foreign.result().status, static_cast<int>(fuse_msgs::RPC_UNAVAILABLE));
  EXPECT_EQ(handled.load(), 1) << "map control ran for someone other than the operator";
  // The server knows who called: the operator's participant, and with Fast DDS the subject of
  // the certificate it authenticated with.
  EXPECT_NE(caller.find("fuse-map-ctl"), std::string::npos) << caller;
  if (GetParam() == "fastdds") {
    EXPECT_NE(caller.find("CN=fuse-map-ctl"), std::string::npos) << caller;
  }
}

TEST_P(Security, GrantIsEnforced) {
  // A planner may call query and read odometry; it may not publish IMU samples or call map
  // control, nor read the scans. Each endpoint is refused where it is created.
  auto planner = make_participant(as("second-planner", 2), "some-planner");
  EXPECT_THROW(Publisher<fuse_msgs::ImuSample>(*planner, topics::kImu), std::runtime_error);
  EXPECT_THROW(Publisher<fuse_msgs::MapControlRequest>(*planner, request_topic(services::kMapControl)),
               std::runtime_error);
  EXPECT_THROW(Subscriber<fuse_msgs::LidarScan>(*planner, topics::kLidarScan, [](const fuse_msgs::LidarScan&) {}),
               std::runtime_error);
  EXPECT_NO_THROW(Publisher<fuse_msgs::QueryRequest>(*planner, request_topic(services::kQuery)));
  EXPECT_NO_THROW(Subscriber<fuse_msgs::StateEstimate>(*planner, topics::kOdometry, [](const fuse_msgs::StateEstimate&) {}));
}

TEST_P(Security, GrantsOfANamedSystemHoldOnlyInItsPartition) {
  // fuse-keystore init --system truck-7: every grant names that partition only.
  static Keystore named("named", "truck-7");
  for (const std::string system : {"truck-7", "truck-8", ""}) {
    TransportConfig c = secured(GetParam(), domain(2), named.path(), "fuse-ingest");
    c.system_name = system;
    auto ingest = make_participant(c, "fuse-ingest");
    if (system == "truck-7") {
      EXPECT_NO_THROW(Publisher<fuse_msgs::ImuSample>(*ingest, topics::kImu));
    } else {
      EXPECT_THROW(Publisher<fuse_msgs::ImuSample>(*ingest, topics::kImu), std::runtime_error) << "system '" << system << "'";
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Vendors, Security, ::testing::ValuesIn(vendors()),
                         [](const ::testing::TestParamInfo<std::string>& i) { return i.param; });

// Secured Fast DDS 2.9 and Cyclone DDS 0.10 across processes (domains 4 and 8): a Fast DDS
// writer reaches a Cyclone reader; a Cyclone writer is never matched by a Fast DDS reader (the
// evidence docs/architecture.md cites: a secured system runs on one vendor).
TEST(SecurityAcrossVendors, FastddsWriterReachesCycloneReaderOnly) {
  for (const auto& [parent, child, d] : {std::tuple<std::string, std::string, int>{"cyclonedds", "fastdds", 8},
                                          {"fastdds", "cyclonedds", 4}}) {
    auto state = make_participant(secured(parent, d, keystore().path()), "fuse-state");
    Inbox<fuse_msgs::ImuSample> inbox;
    Subscriber<fuse_msgs::ImuSample> sub(*state, topics::kImu, std::ref(inbox));
    Child ingest(child, d, keystore().path(), "fuse-ingest", "publish", 15);
    const ChildResult r = ingest.result();
    std::cout << child << " writer -> " << parent << " reader: matched " << r.matched << ", received "
              << inbox.size() << "\n";
    RecordProperty(child + "_to_" + parent + "_received", static_cast<int>(inbox.size()));
    if (parent == "cyclonedds") {
      EXPECT_TRUE(inbox.wait_for(50)) << "secured Fast DDS -> Cyclone DDS no longer works";
    }
  }
}

TEST(SecurityFiles, EveryMissingFileIsNamed) {
  SecurityConfig c;
  c.enabled = true;
  c.keystore = keystore().path();
  EXPECT_EQ(security_files(c, "fuse-state").certificate, c.keystore + "/identities/fuse-state/cert.pem");
  try {
    security_files(c, "nobody");
    FAIL() << "an unknown identity was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("identities/nobody/cert.pem"), std::string::npos) << e.what();
  }
  c.private_key = "/nonexistent/dds-key.pem";
  try {
    security_files(c, "fuse-state");
    FAIL() << "a missing private key was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dds-key.pem"), std::string::npos) << e.what();
  }
  c.private_key.clear();
  c.identity = "../fuse-state";
  EXPECT_THROW(security_files(c, "x"), std::runtime_error);
}

TEST(SecurityDocuments, RolesGrantWhatTheServicesUseAndNoMore) {
  const Grant planner = role_grant("planner");
  EXPECT_EQ(planner.publish, std::vector<std::string>{"rpc/query/request"});
  const Grant ingest = role_grant("ingest");
  EXPECT_NE(std::find(ingest.publish.begin(), ingest.publish.end(), "imu"), ingest.publish.end());
  for (const auto& role : roles()) {
    if (role == "ingest") continue;
    const Grant g = role_grant(role);
    for (const char* t : {topics::kImu, topics::kLidarScan}) {
      EXPECT_EQ(std::find(g.publish.begin(), g.publish.end(), t), g.publish.end()) << role << " may publish " << t;
    }
    const bool controls = std::find(g.publish.begin(), g.publish.end(), "rpc/map/control/request") != g.publish.end();
    EXPECT_EQ(controls, role == "operator") << role;
  }
  EXPECT_THROW(role_grant("root"), std::invalid_argument);
  const std::string xml = permissions_xml("fuse-map", role_grant("map"), "truck-7", {"2026-01-01T00:00:00", "2036-01-01T00:00:00"});
  EXPECT_NE(xml.find("<subject_name>CN=fuse-map</subject_name>"), std::string::npos);
  EXPECT_NE(xml.find("<partition>truck-7</partition>"), std::string::npos);
  EXPECT_NE(xml.find("<default>DENY</default>"), std::string::npos);
  const std::string gov = governance_xml();
  EXPECT_EQ(gov.find("NONE</data_protection_kind>"), std::string::npos);
  EXPECT_NE(gov.find("<allow_unauthenticated_participants>false"), std::string::npos);
}

TEST(SecurityKeystore, ToolRefusesToOverwriteAndUnknownRoles) {
  EXPECT_EQ(Keystore::run("init " + keystore().path()), 2);
  EXPECT_EQ(Keystore::run("add-identity " + keystore().path() + " fuse-state --role state"), 2);
  EXPECT_EQ(Keystore::run("add-identity " + keystore().path() + " x --role root"), 2);
  EXPECT_EQ(Keystore::run("add-identity " + keystore().path() + " ../x --role planner"), 2);
  const auto key = fs::status(keystore().path() + "/identities/fuse-state/key.pem").permissions();
  EXPECT_EQ(key & (fs::perms::group_all | fs::perms::others_all), fs::perms::none);
}

}  // namespace
}  // namespace fuse::transport::test

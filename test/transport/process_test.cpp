// Across processes: this test binary starts itself as an RPC server (DISABLED_Child.QueryServer,
// run only when spawned) and calls it, so discovery and delivery go through the loopback peers
// rather than any in-process shortcut. Same vendor on both sides, and both vendor pairs.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>

#include "test_util.hpp"


namespace fuse::transport::test {
namespace {

using QueryServer = RpcServer<fuse_msgs::QueryRequest, fuse_msgs::QueryReply>;
using QueryClient = RpcClient<fuse_msgs::QueryRequest, fuse_msgs::QueryReply>;

constexpr double kStop = -999.0;  ///< request time that ends the child

// The child: serves queries (estimate.t = 2 t) until asked to stop or 30 s have passed.
TEST(DISABLED_Child, QueryServer) {
  const char* vendor = std::getenv("FUSE_TRANSPORT_CHILD_VENDOR");
  const char* domain = std::getenv("FUSE_TRANSPORT_CHILD_DOMAIN");
  if (vendor == nullptr || domain == nullptr) GTEST_SKIP() << "only run when spawned by CrossProcess";
  auto participant = make_participant(config(vendor, std::atoi(domain)), "child-server");
  std::atomic<bool> stop{false};
  QueryServer server(*participant, services::kQuery, [&](const fuse_msgs::QueryRequest& req, fuse_msgs::QueryReply& rep) {
    if (req.t() == kStop) stop = true;
    rep.estimate().t(2.0 * req.t());
    rep.estimate().frame(vendor);
  });
  wait_until([&] { return stop.load(); }, 30s);
  std::this_thread::sleep_for(300ms);  // let the last reply go out
}

class ChildProcess {
 public:
  ChildProcess(const std::string& vendor, int domain)
      : pid_(spawn_this_test("DISABLED_Child.QueryServer", {"FUSE_TRANSPORT_CHILD_VENDOR=" + vendor,
                                                            "FUSE_TRANSPORT_CHILD_DOMAIN=" + std::to_string(domain)})) {}
  ~ChildProcess() {
    if (pid_ > 0 && !wait(5s)) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  bool started() const { return pid_ > 0; }
  /// True when the child exited (successfully) within the timeout.
  bool wait(std::chrono::milliseconds timeout) {
    int status = 0;
    const bool exited = wait_until([&] { return waitpid(pid_, &status, WNOHANG) == pid_; }, timeout);
    if (exited) {
      exit_ok_ = WIFEXITED(status) && WEXITSTATUS(status) == 0;
      pid_ = -1;
    }
    return exited;
  }
  bool exit_ok() const { return exit_ok_; }

 private:
  pid_t pid_ = -1;
  bool exit_ok_ = false;
};

struct Pair {
  std::string client, server;
  int domain;
};

class CrossProcess : public ::testing::TestWithParam<Pair> {};

TEST_P(CrossProcess, QueryRoundTrips) {
  const Pair pair = GetParam();
  ChildProcess child(pair.server, pair.domain);
  ASSERT_TRUE(child.started());
  auto participant = make_participant(config(pair.client, pair.domain), "parent-client");
  QueryClient client(*participant, services::kQuery);
  ASSERT_TRUE(client.wait_for_server(15s)) << pair.client << " client did not find the " << pair.server << " server";
  for (int i = 1; i <= 5; ++i) {
    fuse_msgs::QueryRequest req;
    req.t(i * 1.5);
    const auto result = client.call(req, 5s);
    ASSERT_TRUE(result.ok()) << result.message;
    EXPECT_EQ(result.reply.estimate().t(), i * 3.0);
    EXPECT_EQ(result.reply.estimate().frame(), pair.server);
  }
  fuse_msgs::QueryRequest stop;
  stop.t(kStop);
  EXPECT_TRUE(client.call(stop, 5s).ok());
  ASSERT_TRUE(child.wait(10s));
  EXPECT_TRUE(child.exit_ok());
}

INSTANTIATE_TEST_SUITE_P(Processes, CrossProcess,
                         ::testing::Values(Pair{"fastdds", "fastdds", 16}, Pair{"cyclonedds", "cyclonedds", 26},
                                           Pair{"fastdds", "cyclonedds", 38}, Pair{"cyclonedds", "fastdds", 39}),
                         [](const auto& info) { return info.param.client + "_to_" + info.param.server; });

}  // namespace
}  // namespace fuse::transport::test

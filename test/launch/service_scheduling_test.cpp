// The services' scheduler slices (config section `scheduling`, fuse/core/scheduling.hpp):
// fuse-state started as a process runs every one of its threads (the transport's among them,
// all but the signal-waiting one) with scheduling.state_slice_us, keeps the kernel's default with 0, and refuses a value the
// kernel would clamp or an unknown key, naming it; it holds scheduling.cpu_latency_us while it
// runs (fuse/core/cpu_latency.hpp). DDS domain 47.
#include <gtest/gtest.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <set>
#include <string>
#include <thread>

#include "fuse/core/cpu_latency.hpp"
#include "fuse/core/scheduling.hpp"
#include "fuse/launch/process.hpp"
#include "test_helpers.hpp"

namespace fuse::launch {
namespace {

using namespace std::chrono_literals;
using test::read_text;
using test::TempDir;

const std::string kConfig = std::string(FUSE_CONFIG_DIR) + "/mid360.yaml";

/// fuse-state with the default config on domain 47 and the given overrides.
Process start_state(const TempDir& dir, const std::vector<std::string>& sets, const std::string& log) {
  std::vector<std::string> argv = {FUSE_STATE_BIN, "--config", kConfig, "--set", "transport.domain_id=47"};
  for (const std::string& s : sets) {
    argv.push_back("--set");
    argv.push_back(s);
  }
  return Process::spawn(argv, dir.str(log));
}

std::set<int> threads_of(pid_t pid) {
  std::set<int> tids;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator("/proc/" + std::to_string(pid) + "/task", ec)) {
    tids.insert(std::stoi(e.path().filename().string()));
  }
  return tids;
}

TEST(ServiceScheduling, EveryFuseStateThreadRunsWithTheConfiguredSlice) {
  int default_slice = 0;
  bool supported = false;
  std::thread([&] {
    default_slice = scheduler_slice_us();
    supported = request_scheduler_slice(kMinSchedulerSliceUs).applied;
  }).join();
  if (!supported) GTEST_SKIP() << "no per-thread scheduler slices on this kernel (Linux 6.12+)";
  for (const int slice : {100, 250, 0}) {
    TempDir dir("fuse-scheduling-test");
    Process p = start_state(dir, {"scheduling.state_slice_us=" + std::to_string(slice)}, "state.log");
    // "running" is logged once the participant and every endpoint exist (their threads started).
    ASSERT_TRUE(test::wait_until([&] { return read_text(dir.str("state.log")).find("running") != std::string::npos; }, 20s))
        << read_text(dir.str("state.log"));
    const std::set<int> tids = threads_of(p.pid());
    EXPECT_GE(tids.size(), 3u) << "main, transport and health threads";
    for (const int tid : tids) {
      const std::string comm = read_text("/proc/" + std::to_string(p.pid()) + "/task/" + std::to_string(tid) + "/comm");
      if (comm == "fuse-signals\n") continue;  // started before the config is read; only waits for SIGTERM
      EXPECT_EQ(scheduler_slice_us(tid), slice > 0 ? slice : default_slice) << "slice " << slice << ", thread " << tid;
    }
    const std::string log = read_text(dir.str("state.log"));
    EXPECT_EQ(log.find("scheduler slice " + std::to_string(slice) + " us") != std::string::npos, slice > 0) << log;
    p.terminate(10s);
  }
}

TEST(ServiceScheduling, ABadSliceOrUnknownKeyStopsTheServiceNamingIt) {
  TempDir dir("fuse-scheduling-test");
  const std::pair<std::string, std::string> cases[] = {{"scheduling.state_slice_us=50", "scheduling.state_slice_us"},
                                                       {"scheduling.update_slice_us=200000", "scheduling.update_slice_us"},
                                                       {"scheduling.planner_slice_us=100", "scheduling.planner_slice_us"},
                                                       {"scheduling.cpu_latency_us=-2", "scheduling.cpu_latency_us"}};
  int n = 0;
  for (const auto& [set, key] : cases) {
    const std::string log = "bad" + std::to_string(++n) + ".log";
    Process p = start_state(dir, {set}, log);
    const auto status = p.wait_for(20s);
    ASSERT_TRUE(status) << set;
    EXPECT_EQ(status->code, 2) << set;
    EXPECT_NE(read_text(dir.str(log)).find(key), std::string::npos) << read_text(dir.str(log));
  }
}

TEST(ServiceScheduling, FuseStateHoldsTheCpuLatencyBoundWhileItRuns) {
  if (::access(kCpuLatencyDevice, W_OK) != 0) {
    GTEST_SKIP() << kCpuLatencyDevice << " is not writable here (needs root or the deploy's udev rule)";
  }
  TempDir dir("fuse-scheduling-test");
  Process p = start_state(dir, {"scheduling.cpu_latency_us=3"}, "latency.log");
  ASSERT_TRUE(test::wait_until([&] { return read_text(dir.str("latency.log")).find("running") != std::string::npos; }, 20s))
      << read_text(dir.str("latency.log"));
  EXPECT_NE(read_text(dir.str("latency.log")).find("CPU wake-up latency bound 3 us held"), std::string::npos)
      << read_text(dir.str("latency.log"));
  const int in_force = cpu_latency_in_force_us();
  EXPECT_GE(in_force, 0);
  EXPECT_LE(in_force, 3);
  p.terminate(10s);
  // -1 asks for nothing.
  Process q = start_state(dir, {"scheduling.cpu_latency_us=-1"}, "none.log");
  ASSERT_TRUE(test::wait_until([&] { return read_text(dir.str("none.log")).find("running") != std::string::npos; }, 20s));
  EXPECT_EQ(read_text(dir.str("none.log")).find("CPU wake-up latency"), std::string::npos) << read_text(dir.str("none.log"));
  q.terminate(10s);
}

}  // namespace
}  // namespace fuse::launch

// ProcessSupervisor with small shell scripts as services: log capture, kill -9 and restart with
// backoff, restart limit, completion, ordered stop and SIGKILL escalation.
#include <gtest/gtest.h>

#include <csignal>

#include "fuse/launch/process_supervisor.hpp"
#include "test_helpers.hpp"

namespace fuse::launch {
namespace {

using namespace std::chrono_literals;
using test::read_text;
using test::write_script;

class Supervisor : public ::testing::Test {
 protected:
  SupervisorOptions options() const {
    SupervisorOptions o;
    o.log_dir = dir_.str("logs");
    o.restart_backoff = 50ms;
    o.max_restarts = 3;
    return o;
  }
  ServiceSpec spec(const std::string& name, const std::string& body, bool restart = false) {
    return ServiceSpec{name, {write_script(dir_.str(name + ".sh"), body)}, restart, false};
  }
  /// A service that logs "ready", then waits; on SIGTERM it appends its name to stop_order.
  std::string well_behaved(const std::string& name) const {
    return "trap 'echo " + name + " >> " + dir_.str("stop_order") + "; exit 0' TERM\necho ready\n"
           "while :; do sleep 0.05; done";
  }
  bool poll_until(ProcessSupervisor& s, const std::function<bool()>& done, std::chrono::milliseconds timeout) {
    return test::wait_until([&] { s.poll(); return done(); }, timeout);
  }
  bool logged(ProcessSupervisor& s, const std::string& name, const std::string& what) {
    return read_text(s.log_path(name)).find(what) != std::string::npos;
  }

  test::TempDir dir_;
};

TEST_F(Supervisor, LogsEachServiceUnderItsName) {
  ProcessSupervisor s(options());
  s.start(spec("alpha", "echo alpha-out; echo alpha-err >&2; exec sleep 30"));
  EXPECT_EQ(s.log_path("alpha"), dir_.str("logs/alpha.log"));
  EXPECT_TRUE(s.is_running("alpha"));
  ASSERT_TRUE(test::wait_until([&] { return logged(s, "alpha", "alpha-err"); }, 5s));
  EXPECT_TRUE(logged(s, "alpha", "alpha-out"));
  EXPECT_TRUE(logged(s, "alpha", "[fuse-launch] start 1: ")) << "the launcher notes each start";
  EXPECT_THROW(s.start(spec("alpha", "exit 0")), std::invalid_argument);
  EXPECT_THROW(s.state("nobody"), std::invalid_argument);
}

TEST_F(Supervisor, RestartsAServiceKilledWithSigkill) {
  ProcessSupervisor s(options());
  s.start(spec("state", "echo started\nexec sleep 30", true));
  const pid_t first = s.pid("state");
  ASSERT_GT(first, 0);
  ASSERT_TRUE(test::wait_until([&] { return logged(s, "state", "started"); }, 5s));
  ASSERT_TRUE(s.signal("state", SIGKILL));
  ASSERT_TRUE(poll_until(s, [&] { return s.restarts("state") == 1 && s.state("state") == ServiceState::running; }, 5s));
  EXPECT_NE(s.pid("state"), first);
  const ServiceReport r = s.report("state");
  ASSERT_TRUE(r.last_exit);
  EXPECT_TRUE(r.last_exit->signaled);
  EXPECT_EQ(r.last_exit->signal, SIGKILL);
  ASSERT_TRUE(test::wait_until([&] { return test::count(read_text(s.log_path("state")), "started") == 2; }, 5s));
  EXPECT_TRUE(logged(s, "state", "[fuse-launch] start 2: "));
}

TEST_F(Supervisor, WithoutRestartADeadServiceHasFailed) {
  ProcessSupervisor s(options());
  s.start(spec("update", "exec sleep 30"));
  s.signal("update", SIGKILL);
  ASSERT_TRUE(poll_until(s, [&] { return s.state("update") == ServiceState::failed; }, 5s));
  EXPECT_EQ(s.restarts("update"), 0);
  EXPECT_FALSE(s.is_running("update"));
  EXPECT_EQ(s.pid("update"), -1);
}

TEST_F(Supervisor, GivesUpAfterMaxRestartsWithAGrowingBackoff) {
  ProcessSupervisor s(options());  // 3 restarts, 50 + 100 + 200 ms
  const auto start = std::chrono::steady_clock::now();
  s.start(spec("crasher", "echo crash; exit 1", true));
  ASSERT_TRUE(poll_until(s, [&] { return s.state("crasher") == ServiceState::failed; }, 10s));
  EXPECT_GE(test::seconds_since(start), 0.35);
  EXPECT_EQ(s.restarts("crasher"), 3);
  EXPECT_EQ(test::count(read_text(s.log_path("crasher")), "crash\n"), 4);
  EXPECT_EQ(s.report("crasher").last_exit->code, 1);
}

TEST_F(Supervisor, AHealthyRunStartsTheRestartCountAfresh) {
  SupervisorOptions o = options();  // at most 3 early deaths in a row
  o.healthy_after = 300ms;
  ProcessSupervisor s(o);
  // Lives 0.4 s (healthy) each time, then dies: ten deaths are ten fresh starts, never given up.
  s.start(spec("soak", "echo up; sleep 0.4; exit 1", true));
  ASSERT_TRUE(poll_until(s, [&] { return s.restarts("soak") >= 6; }, 20s));
  EXPECT_NE(s.state("soak"), ServiceState::failed) << s.report("soak").failure;
  EXPECT_LE(s.report("soak").early_deaths, 1);
}

TEST_F(Supervisor, UsageAndInputErrorsAreNotRestarted) {
  ProcessSupervisor s(options());
  s.start(spec("config", "echo 'bad key'; exit 2", true));
  s.start(spec("input", "echo 'cannot open input'; exit 4", true));
  ASSERT_TRUE(poll_until(s, [&] { return s.state("config") == ServiceState::failed && s.state("input") == ServiceState::failed; },
                         5s));
  EXPECT_EQ(s.restarts("config"), 0);
  EXPECT_EQ(s.restarts("input"), 0);
  EXPECT_NE(s.report("config").failure.find("restarting cannot fix it"), std::string::npos) << s.report("config").failure;
  EXPECT_NE(s.report("input").failure.find("input cannot be read"), std::string::npos) << s.report("input").failure;
}

TEST_F(Supervisor, ExitZeroIsCompletionWhenTheSpecSaysSo) {
  ProcessSupervisor s(options());
  ServiceSpec ingest = spec("ingest", "sleep 0.1; exit 0", true);
  ingest.exit_zero_is_done = true;
  s.start(ingest);
  const auto status = s.wait("ingest", 5s);
  ASSERT_TRUE(status);
  EXPECT_TRUE(status->success());
  EXPECT_EQ(s.state("ingest"), ServiceState::done);
  s.poll();
  EXPECT_EQ(s.restarts("ingest"), 0);
}

TEST_F(Supervisor, WaitReturnsTheExitOrNothingBeforeTheTimeout) {
  ProcessSupervisor s(options());
  s.start(spec("slow", "sleep 0.3; exit 4"));
  EXPECT_FALSE(s.wait("slow", 50ms));
  const auto status = s.wait("slow", 5s);
  ASSERT_TRUE(status);
  EXPECT_EQ(status->code, 4);
  EXPECT_EQ(s.state("slow"), ServiceState::failed);
  EXPECT_FALSE(s.wait("slow", 50ms)) << "nothing left to wait for";
}

TEST_F(Supervisor, StopsInReverseStartOrder) {
  ProcessSupervisor s(options());
  for (const std::string name : {"map", "state", "update"}) s.start(spec(name, well_behaved(name)));
  for (const std::string name : {"map", "state", "update"}) {
    ASSERT_TRUE(test::wait_until([&] { return logged(s, name, "ready"); }, 5s));
  }
  const auto reports = s.stop_all(5s);
  ASSERT_EQ(reports.size(), 3u);
  EXPECT_EQ(reports[0].name, "update");
  EXPECT_EQ(reports[2].name, "map");
  for (const auto& r : reports) {
    EXPECT_EQ(r.state, ServiceState::stopped);
    EXPECT_FALSE(r.escalated);
    ASSERT_TRUE(r.last_exit);
    EXPECT_TRUE(r.last_exit->success()) << r.name << ": " << r.last_exit->describe();
  }
  EXPECT_EQ(read_text(dir_.str("stop_order")), "update\nstate\nmap\n");
}

TEST_F(Supervisor, StopEscalatesToSigkillAndAStoppedServiceIsNotRestarted) {
  ProcessSupervisor s(options());
  s.start(spec("stubborn", "trap '' TERM\necho ready\nwhile :; do sleep 0.05; done", true));
  ASSERT_TRUE(test::wait_until([&] { return logged(s, "stubborn", "ready"); }, 5s));
  const auto start = std::chrono::steady_clock::now();
  const ServiceReport r = s.stop("stubborn", 200ms);
  EXPECT_GE(test::seconds_since(start), 0.2);
  EXPECT_TRUE(r.escalated);
  EXPECT_EQ(r.state, ServiceState::stopped);
  EXPECT_EQ(r.last_exit->signal, SIGKILL);
  std::this_thread::sleep_for(150ms);
  s.poll();
  EXPECT_EQ(s.state("stubborn"), ServiceState::stopped);
  EXPECT_EQ(s.restarts("stubborn"), 0);
}

TEST_F(Supervisor, StoppingDuringTheBackoffCancelsTheRestart) {
  SupervisorOptions o = options();
  o.restart_backoff = 10s;
  ProcessSupervisor s(o);
  s.start(spec("state", "exec sleep 30", true));
  s.signal("state", SIGKILL);
  ASSERT_TRUE(poll_until(s, [&] { return s.state("state") == ServiceState::restarting; }, 5s));
  const ServiceReport r = s.stop("state", 1s);
  EXPECT_EQ(r.state, ServiceState::stopped);
  EXPECT_TRUE(r.down_at_stop);  // not a service that failed to stop: the launcher does not fail the run
  s.poll();
  EXPECT_EQ(s.restarts("state"), 0);
}

TEST_F(Supervisor, DestructorStopsWhatIsStillRunning) {
  pid_t pid = -1;
  {
    ProcessSupervisor s(options());
    s.start(spec("left", "exec sleep 30"));
    pid = s.pid("left");
  }
  EXPECT_NE(::kill(pid, 0), 0);
}

}  // namespace
}  // namespace fuse::launch

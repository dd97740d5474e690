// Process: spawn with argv and a log file, exit status, signal, wait with timeout, terminate
// with SIGKILL escalation, and no process left behind.
#include <gtest/gtest.h>

#include <csignal>

#include "fuse/launch/process.hpp"
#include "test_helpers.hpp"

namespace fuse::launch {
namespace {

using namespace std::chrono_literals;
using test::read_text;
using test::TempDir;
using test::write_script;

bool alive(pid_t pid) { return ::kill(pid, 0) == 0; }

TEST(Process, LogCapturesStdoutAndStderrAndTheExitCode) {
  TempDir dir;
  const auto script = write_script(dir.str("s.sh"), "echo to-stdout; echo to-stderr >&2; exit 3");
  Process p = Process::spawn({script}, dir.str("s.log"));
  const auto status = p.wait_for(5s);
  ASSERT_TRUE(status);
  EXPECT_FALSE(status->signaled);
  EXPECT_EQ(status->code, 3);
  EXPECT_EQ(status->describe(), "exit code 3");
  const std::string log = read_text(dir.str("s.log"));
  EXPECT_NE(log.find("to-stdout"), std::string::npos) << log;
  EXPECT_NE(log.find("to-stderr"), std::string::npos) << log;
}

TEST(Process, PassesArgvUnchangedAndAppendsToTheLog) {
  TempDir dir;
  const auto script = write_script(dir.str("s.sh"), "for a in \"$@\"; do echo \"[$a]\"; done");
  test::write_text(dir.str("s.log"), "earlier\n");
  Process p = Process::spawn({script, "a b", "--set", "x.y=1"}, dir.str("s.log"));
  ASSERT_TRUE(p.wait_for(5s));
  EXPECT_EQ(read_text(dir.str("s.log")), "earlier\n[a b]\n[--set]\n[x.y=1]\n");
}

TEST(Process, WaitTimesOutWhileRunningThenSeesTheSignal) {
  TempDir dir;
  Process p = Process::spawn({write_script(dir.str("s.sh"), "exec sleep 30")}, dir.str("s.log"));
  EXPECT_FALSE(p.wait_for(100ms));
  EXPECT_TRUE(p.is_running());
  EXPECT_TRUE(p.signal(SIGTERM));
  const auto status = p.wait_for(5s);
  ASSERT_TRUE(status);
  EXPECT_TRUE(status->signaled);
  EXPECT_EQ(status->signal, SIGTERM);
  EXPECT_FALSE(p.is_running());
  EXPECT_FALSE(p.signal(SIGTERM)) << "a reaped process is not signalled";
}

TEST(Process, TerminateIsGracefulWhenTheChildHandlesSigterm) {
  TempDir dir;
  const auto script = write_script(dir.str("s.sh"),
                                   "trap 'echo bye; exit 0' TERM\necho ready\nwhile :; do sleep 0.05; done");
  Process p = Process::spawn({script}, dir.str("s.log"));
  ASSERT_TRUE(test::wait_until([&] { return read_text(dir.str("s.log")).find("ready") != std::string::npos; }, 5s));
  const auto t = p.terminate(5s);
  EXPECT_FALSE(t.escalated);
  EXPECT_TRUE(t.status.success()) << t.status.describe();
  EXPECT_NE(read_text(dir.str("s.log")).find("bye"), std::string::npos);
}

TEST(Process, TerminateEscalatesToSigkillAfterTheTimeout) {
  TempDir dir;
  const auto script = write_script(dir.str("s.sh"), "trap '' TERM\necho ready\nwhile :; do sleep 0.05; done");
  Process p = Process::spawn({script}, dir.str("s.log"));
  ASSERT_TRUE(test::wait_until([&] { return read_text(dir.str("s.log")).find("ready") != std::string::npos; }, 5s));
  const auto start = std::chrono::steady_clock::now();
  const auto t = p.terminate(300ms);
  const double elapsed = test::seconds_since(start);
  EXPECT_TRUE(t.escalated);
  EXPECT_TRUE(t.status.signaled);
  EXPECT_EQ(t.status.signal, SIGKILL);
  EXPECT_EQ(t.status.describe(), "killed by signal 9 (SIGKILL)");
  EXPECT_GE(elapsed, 0.3);
  EXPECT_LT(elapsed, 3.0);
}

TEST(Process, SignalsReachTheChildsOwnChildren) {
  TempDir dir;
  const auto script = write_script(dir.str("s.sh"), "sleep 30 &\necho $! > " + dir.str("grandchild") + "\nwait");
  Process p = Process::spawn({script}, dir.str("s.log"));
  ASSERT_TRUE(test::wait_until([&] { return !read_text(dir.str("grandchild")).empty(); }, 5s));
  const pid_t grandchild = std::stoi(read_text(dir.str("grandchild")));
  EXPECT_TRUE(alive(grandchild));
  p.terminate(2s);
  EXPECT_TRUE(test::wait_until([&] { return !alive(grandchild); }, 2s)) << "the group got SIGTERM";
}

TEST(Process, DestructorKillsAndReapsARunningChild) {
  TempDir dir;
  pid_t pid = -1;
  {
    Process p = Process::spawn({write_script(dir.str("s.sh"), "exec sleep 30")}, dir.str("s.log"));
    pid = p.pid();
    EXPECT_TRUE(alive(pid));
  }
  EXPECT_FALSE(alive(pid)) << "killed and reaped (no zombie)";
}

TEST(Process, RefusesAMissingExecutableAndAnUnwritableLog) {
  TempDir dir;
  EXPECT_THROW(Process::spawn({dir.str("missing")}, dir.str("s.log")), std::runtime_error);
  EXPECT_THROW(Process::spawn({}, dir.str("s.log")), std::runtime_error);
  const auto script = write_script(dir.str("s.sh"), "exit 0");
  EXPECT_THROW(Process::spawn({script}, dir.str("no/such/dir/s.log")), std::runtime_error);
}

}  // namespace
}  // namespace fuse::launch

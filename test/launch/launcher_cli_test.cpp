// fuse-launch with stand-in services (shell scripts in a --bin-dir): start order and arguments,
// stop in reverse order when the replay is done, failures, --restart, SIGTERM to the launcher,
// SIGKILL escalation and usage errors. DDS domains 45 and 46 belong to this file.
#include <gtest/gtest.h>

#include <csignal>

#include "fuse/launch/process.hpp"
#include "test_helpers.hpp"

namespace fuse::launch {
namespace {

using namespace std::chrono_literals;
using test::read_text;
using test::write_script;

const char* kServices[] = {"fuse-map", "fuse-state", "fuse-update"};

class LauncherCli : public ::testing::Test {
 protected:
  void SetUp() override {
    std::filesystem::create_directories(bin());
    // Its own DDS domain: fuse-launch watches the bus, and must not see another test's services.
    test::write_text(dir_.str("config.yaml"), "transport:\n  vendor: fastdds\n  domain_id: 46\n");
    test::write_text(dir_.str("recording.mcap"), "");
    for (const char* name : kServices) service(name, "");
    ingest("sleep 0.3; echo replay-done; exit 0");
  }

  std::string bin() const { return dir_.str("bin"); }
  std::string out() const { return dir_.str("out"); }

  /// A stand-in service: records its arguments, runs `before` (may exit), logs "ready", then
  /// waits; on SIGTERM it appends its name to stop_order and exits 0.
  void service(const std::string& name, const std::string& before) {
    write_script(bin() + "/" + name, "printf '%s\\n' \"$@\" > " + dir_.str(name + ".args") + "\n" + before + "\n" +
                                         "trap 'echo " + name + " >> " + dir_.str("stop_order") + "; exit 0' TERM\n" +
                                         "echo ready\nwhile :; do sleep 0.05; done");
  }
  void ingest(const std::string& body) {
    write_script(bin() + "/fuse-ingest", "printf '%s\\n' \"$@\" > " + dir_.str("fuse-ingest.args") + "\n" +
                                             "trap 'echo fuse-ingest >> " + dir_.str("stop_order") + "; exit 0' TERM\n" + body);
  }

  struct Run {
    int code = -1;
    std::string output;
  };
  /// Runs fuse-launch with the common arguments plus `extra`; its output goes to launcher.log.
  Run launch(std::vector<std::string> extra, bool with_defaults = true) {
    std::vector<std::string> argv{FUSE_LAUNCH_BIN};
    if (with_defaults) {
      argv.insert(argv.end(), {"--config", dir_.str("config.yaml"), "--input", dir_.str("recording.mcap"), "--out",
                               out(), "--bin-dir", bin(), "--settle-ms", "100"});
    }
    argv.insert(argv.end(), extra.begin(), extra.end());
    Process p = Process::spawn(argv, dir_.str("launcher.log"));
    const auto status = p.wait_for(30s);
    Run r;
    r.output = read_text(dir_.str("launcher.log"));
    if (status && !status->signaled) r.code = status->code;
    return r;
  }
  std::string args_of(const std::string& name) const { return read_text(dir_.str(name + ".args")); }

  test::TempDir dir_;
};

TEST_F(LauncherCli, StartsTheServicesAndStopsThemInReverseWhenTheReplayIsDone) {
  const Run r = launch({"--mode", "realtime", "--rate", "2", "--domain", "45", "--vendor", "cyclonedds", "--set",
                        "estimator.update.max_iterations=3"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(read_text(dir_.str("stop_order")), "fuse-update\nfuse-state\nfuse-map\n");
  const std::string common = "--config\n" + dir_.str("config.yaml") +
                             "\n--set\nestimator.update.max_iterations=3\n--set\ntransport.domain_id=45\n"
                             "--set\ntransport.vendor=cyclonedds\n";
  EXPECT_EQ(args_of("fuse-map"), common + "--map-dir\n" + out() + "/map\n--set\nmap_server.spill_directory=" + out() +
                                    "/map-spill\n");
  EXPECT_EQ(args_of("fuse-state"), common + "--trajectory\n" + out() + "/trajectory.tum\n--calibration-from\n" +
                                       dir_.str("recording.mcap") + "\n--set\nstate.checkpoint_file=" + out() +
                                       "/state.checkpoint\n");
  EXPECT_EQ(args_of("fuse-update"), common);
  const std::string ingest = args_of("fuse-ingest");
  EXPECT_EQ(ingest.rfind(common + "--input\n" + dir_.str("recording.mcap") + "\n--mode\nrealtime\n--rate\n2\n--start-wall\n", 0), 0u)
      << ingest;
  const double start_wall = std::stod(ingest.substr(ingest.rfind("--start-wall\n") + 13));
  const double now = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
  EXPECT_NEAR(start_wall, now, 30.0);
  for (const char* name : {"fuse-map", "fuse-state", "fuse-update"}) {
    EXPECT_NE(read_text(out() + "/logs/" + name + ".log").find("ready"), std::string::npos) << name;
  }
  EXPECT_NE(read_text(out() + "/logs/fuse-ingest.log").find("replay-done"), std::string::npos);
  EXPECT_NE(r.output.find("result: ok"), std::string::npos) << r.output;
}

TEST_F(LauncherCli, LockstepIsTheDefaultAndHasNoStartWall) {
  const Run r = launch({});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(args_of("fuse-ingest"), "--config\n" + dir_.str("config.yaml") + "\n--input\n" +
                                        dir_.str("recording.mcap") + "\n--mode\nlockstep\n");
  EXPECT_EQ(args_of("fuse-map"), "--config\n" + dir_.str("config.yaml") + "\n--map-dir\n" + out() +
                                    "/map\n--set\nmap_server.spill_directory=" + out() + "/map-spill\n");
}

TEST_F(LauncherCli, ExplicitMapDirIsPassed) {
  ASSERT_EQ(launch({"--map-dir", dir_.str("maps")}).code, 0);
  EXPECT_NE(args_of("fuse-map").find("--map-dir\n" + dir_.str("maps") + "\n"), std::string::npos);
}

TEST_F(LauncherCli, DefaultBinDirIsTheLaunchersOwnDirectory) {
  std::filesystem::copy_file(FUSE_LAUNCH_BIN, bin() + "/fuse-launch");
  Process p = Process::spawn({bin() + "/fuse-launch", "--config", dir_.str("config.yaml"), "--input",
                              dir_.str("recording.mcap"), "--out", out(), "--settle-ms", "50"},
                             dir_.str("launcher.log"));
  const auto status = p.wait_for(30s);
  ASSERT_TRUE(status);
  EXPECT_EQ(status->code, 0) << read_text(dir_.str("launcher.log"));
  EXPECT_FALSE(args_of("fuse-state").empty());
}

TEST_F(LauncherCli, AServiceThatDiesFailsTheRunAndStopsTheOthers) {
  service("fuse-update", "sleep 0.2; exit 1");
  ingest("sleep 20; exit 0");
  const auto start = std::chrono::steady_clock::now();
  const Run r = launch({});
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_LT(test::seconds_since(start), 10.0);
  EXPECT_NE(r.output.find("fuse-update failed (exit code 1)"), std::string::npos) << r.output;
  EXPECT_EQ(read_text(dir_.str("stop_order")), "fuse-ingest\nfuse-state\nfuse-map\n");
}

TEST_F(LauncherCli, AFailedReplayFailsTheRun) {
  ingest("exit 3");
  const Run r = launch({});
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("fuse-ingest failed (exit code 3)"), std::string::npos) << r.output;
}

TEST_F(LauncherCli, RestartBringsBackAServiceKilledWithSigkill) {
  // The first fuse-state kills itself with SIGKILL; the restarted one runs normally.
  service("fuse-state", "if [ ! -e " + dir_.str("died") + " ]; then touch " + dir_.str("died") + "; kill -9 $$; fi");
  ingest("sleep 1.5; exit 0");
  const Run r = launch({"--restart"});
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("fuse-state: stopped, exit code 0, restarts 1"), std::string::npos) << r.output;
  const std::string log = read_text(out() + "/logs/fuse-state.log");
  EXPECT_NE(log.find("[fuse-launch] start 2: "), std::string::npos) << log;
  EXPECT_NE(r.output.find("(1 of at most 5 in a row)"), std::string::npos) << "the restart is logged";
}

TEST_F(LauncherCli, WithoutRestartTheSameDeathFailsTheRun) {
  service("fuse-state", "kill -9 $$");
  ingest("sleep 5; exit 0");
  const Run r = launch({});
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_NE(r.output.find("fuse-state failed (killed by signal 9 (SIGKILL))"), std::string::npos) << r.output;
}

TEST_F(LauncherCli, SigtermToTheLauncherStopsEverythingCleanly) {
  ingest("echo ready\nwhile :; do sleep 0.05; done");
  Process p = Process::spawn({FUSE_LAUNCH_BIN, "--config", dir_.str("config.yaml"), "--input",
                              dir_.str("recording.mcap"), "--out", out(), "--bin-dir", bin(), "--settle-ms", "50"},
                             dir_.str("launcher.log"));
  ASSERT_TRUE(test::wait_until([&] { return read_text(out() + "/logs/fuse-ingest.log").find("ready") != std::string::npos; }, 10s));
  ASSERT_TRUE(p.signal(SIGTERM));
  const auto status = p.wait_for(10s);
  ASSERT_TRUE(status);
  EXPECT_EQ(status->code, 0) << read_text(dir_.str("launcher.log"));
  EXPECT_EQ(read_text(dir_.str("stop_order")), "fuse-ingest\nfuse-update\nfuse-state\nfuse-map\n");
  EXPECT_NE(read_text(dir_.str("launcher.log")).find("(interrupted)"), std::string::npos);
}

TEST_F(LauncherCli, AServiceIgnoringSigtermIsKilledAndFailsTheRun) {
  write_script(bin() + "/fuse-map", "trap '' TERM\necho ready\nwhile :; do sleep 0.05; done");
  const auto start = std::chrono::steady_clock::now();
  const Run r = launch({"--stop-timeout-ms", "300"});
  EXPECT_EQ(r.code, 1) << r.output;
  EXPECT_LT(test::seconds_since(start), 10.0);
  EXPECT_NE(r.output.find("fuse-map ignored SIGTERM and was killed"), std::string::npos) << r.output;
}

TEST_F(LauncherCli, UsageErrorsExitWithTwoBeforeStartingAnything) {
  EXPECT_EQ(launch({"--input", dir_.str("recording.mcap")}, false).code, 2);
  EXPECT_EQ(launch({"--mode", "fast"}).code, 2);
  EXPECT_EQ(launch({"--domain", "500"}).code, 2);
  EXPECT_EQ(launch({"--vendor", "opendds"}).code, 2);
  EXPECT_EQ(launch({"--rate", "-1"}).code, 2);
  EXPECT_EQ(launch({"--bogus"}).code, 2);
  EXPECT_EQ(launch({"--config", dir_.str("config.yaml"), "--input", dir_.str("missing.mcap"), "--bin-dir", bin()}, false).code, 2);
  std::filesystem::remove(bin() + "/fuse-update");
  const Run r = launch({});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.output.find("fuse-update"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir_.str("fuse-map.args"))) << "nothing was started";
}

}  // namespace
}  // namespace fuse::launch

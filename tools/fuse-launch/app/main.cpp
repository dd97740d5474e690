// fuse-launch: runs one FUSE deployment on a recording (DESIGN §2).
//
//   fuse-launch --config FILE --input PATH [--mode lockstep|realtime] [--rate R] [--out DIR]
//               [--map-dir DIR] [--domain N] [--vendor fastdds|cyclonedds] [--set key=value]...
//               [--system NAME] [--bin-dir DIR] [--restart]
//
// Starts fuse-map, fuse-state and fuse-update, then fuse-ingest; when the replay is done it stops
// the others in reverse order. SIGINT/SIGTERM stop everything the same way. Meanwhile it watches
// the bus (RunMonitor), logs a progress line every 5 s while the replay runs, and prints a summary
// of restarts, gaps, counters and anything lost.
// Exit codes: 0 every service did its part and nothing was lost (data gaps are not losses),
// 1 a service failed, or another instance of a service runs on this domain under the same
// system name (another system with the same transport.system_name), 2 usage or config, 3 the run
// lost something (named in the summary).
#include <csignal>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <optional>

#include "arguments.hpp"
#include "fuse/core/logging.hpp"
#include "fuse/io/mcap_source.hpp"
#include "fuse/launch/launcher.hpp"
#include "fuse/launch/replay_progress.hpp"
#include "run_monitor.hpp"

namespace {
constexpr int kExitOk = 0, kExitFailed = 1, kExitUsage = 2, kExitLost = 3;
/// Lead from starting fuse-ingest to the replay's first sample (its --start-wall, realtime).
constexpr double kReplayLeadSeconds = 1.0;

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

std::string own_directory(const char* argv0) {
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return (ec ? std::filesystem::absolute(argv0) : exe).parent_path().string();
}

/// The IMU samples and scans the input holds, when it says so without being read through (an MCAP
/// recording's statistics); unset for a sequence directory, a bag, a pcap or a damaged file.
/// fuse-ingest reports an input it cannot read itself.
std::optional<std::uint64_t> replay_events(const std::string& input) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(input, ec)) return std::nullopt;
  try {
    return fuse::io::McapSource(input).expected_events();
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

double unix_now() {
  using namespace std::chrono;
  return duration<double>(system_clock::now().time_since_epoch()).count();
}
}  // namespace

int main(int argc, char** argv) {
  using namespace fuse;
  launch_tool::Arguments args;
  launch::LaunchPlan plan;
  service::SystemConfig config;
  if (const std::optional<int> code = launch_tool::parse_arguments(argc, argv, args)) return *code;
  try {
    if (args.launch.bin_dir.empty()) args.launch.bin_dir = own_directory(argv[0]);
    const double start_wall = unix_now() + std::chrono::duration<double>(args.timing.settle).count() + kReplayLeadSeconds;
    plan = launch::make_launch_plan(args.launch, start_wall);
    launch_tool::check_paths(plan, args.launch);
  } catch (const std::exception& e) {
    std::cerr << "fuse-launch: " << e.what() << "\n";
    return kExitUsage;
  }
  try {  // the services' own config, checked before any of them starts (they would refuse it too)
    config = service::load_system_config(args.launch.config_file, launch::service_overrides(args.launch));
  } catch (const std::exception& e) {
    std::cerr << "fuse-launch: config error: " << e.what() << "\n";
    return kExitUsage;
  }
  const std::optional<std::uint64_t> total_events = replay_events(args.launch.input);
  logger("launch")->info("{}", launch::describe_replay_size(total_events));
  install_signal_handlers();
  launch::LaunchOutcome outcome;
  std::string conflict;
  try {
    launch::SupervisorOptions options;
    options.log_dir = plan.log_dir;
    options.max_restarts = args.max_restarts;
    launch::ProcessSupervisor supervisor(options);
    launch_tool::RunMonitor monitor(config, plan.trajectory_file, plan.map_dir, total_events);
    outcome = launch::run_launch(
        plan, supervisor, args.timing, [&monitor] { return g_stop != 0 || !monitor.conflict().empty(); },
        [&monitor] { monitor.poll(); });
    const launch_tool::RunMonitor::Verdict verdict = monitor.finish(outcome.reports);
    outcome.losses = verdict.losses;
    std::cout << verdict.summary;
    conflict = monitor.conflict();
    if (!conflict.empty()) {
      outcome.success = false;
      outcome.failure = conflict;
      outcome.interrupted = false;  // stopped because of it, not by a signal
    }
  } catch (const std::exception& e) {  // e.g. the log directory cannot be created
    logger("launch")->error("{}", e.what());
    return kExitFailed;
  }
  std::cout << launch::summarize(outcome);
  if (!outcome.success) return kExitFailed;
  return outcome.losses.empty() ? kExitOk : kExitLost;
}

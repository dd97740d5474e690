#include "arguments.hpp"

#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "fuse/cli/cli.hpp"

namespace fuse::launch_tool {

namespace {
long parse_int(const std::string& name, const std::string& text, long min, long max) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || v < min || v > max) {
    throw ArgumentError(name + ": '" + text + "' is not an integer in " + std::to_string(min) + ".." +
                        std::to_string(max));
  }
  return v;
}

double parse_rate(const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v) || v <= 0.0) {
    throw ArgumentError("--rate: '" + text + "' is not a positive number");
  }
  return v;
}
}  // namespace

std::optional<int> parse_arguments(int argc, char** argv, Arguments& a) {
  launch::LaunchOptions& o = a.launch;
  const auto app = cli::make_app(
      "fuse-launch",
      "Starts fuse-map, fuse-state, fuse-update (with --viz also fuse-viz), then fuse-ingest replaying PATH; when "
      "the replay is done, stops "
      "the others (the last started first; SIGKILL after --stop-timeout-ms). Watches the bus and ends with a "
      "summary of restarts, data gaps, counters and what was lost.",
      "Exit codes: 0 every service did its part and nothing was lost, 1 a service failed (its last error line is "
      "printed) or another instance of a service runs under the same system name on this domain, 2 usage or "
      "config, 3 the run lost something (named in the summary).");
  std::string rate, domain, max_restarts, stop_timeout, settle;
  app->add_option("--config", o.config_file, "the system config, passed to every service")->type_name("FILE")->required();
  app->add_option("--input", o.input, "the recording or sequence directory fuse-ingest replays")
      ->type_name("PATH")
      ->required();
  app->add_option("--mode", o.mode, "replay pace (default lockstep)")
      ->type_name("lockstep|realtime")
      ->check(CLI::IsMember({"lockstep", "realtime"}));
  app->add_option("--rate", rate, "replay speed factor, > 0 (realtime)")->type_name("R");
  app->add_option("--out", o.out_dir, "logs/<service>.log, trajectory.tum, map/ (default fuse_out)")->type_name("DIR");
  app->add_option("--map-dir", o.map_dir, "fuse-map's map directory (default OUT/map)")->type_name("DIR");
  app->add_option("--domain", domain, "DDS domain id 0..101, passed to every service")->type_name("N");
  app->add_option("--vendor", o.vendor, "DDS implementation, passed to every service")
      ->type_name("fastdds|cyclonedds")
      ->check(CLI::IsMember({"fastdds", "cyclonedds"}));
  std::optional<std::string> system;
  app->add_option("--system", system,
                  "the system's name, its DDS partition, passed to every service: --set transport.system_name=NAME")
      ->type_name("NAME");
  app->add_option("--set", o.overrides, "a config override for every service (repeatable)")
      ->type_name("KEY=VALUE")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  app->add_option("--bin-dir", o.bin_dir, "where the service binaries are (default: the launcher's own directory)")
      ->type_name("DIR");
  app->add_flag("--restart", o.restart,
                "restart a service that dies unexpectedly (backoff 250 ms, doubling over early deaths; fuse-ingest "
                "only in realtime mode); not one that exits 2 or 4");
  app->add_flag("--viz", o.viz,
                "also run fuse-viz, the live view: a Foxglove WebSocket server on viz.address:viz.port "
                "(127.0.0.1:8765 by default) to open in Foxglove or Lichtblick");
  app->add_option("--max-restarts", max_restarts, "restarts in a row before giving up, 0..1000 (default 5)")
      ->type_name("N");
  app->add_option("--stop-timeout-ms", stop_timeout, "SIGKILL a service this long after SIGTERM (default 5000)")
      ->type_name("N");
  app->add_option("--settle-ms", settle, "pause between starting the services and fuse-ingest (default 500)")
      ->type_name("N");
  if (const std::optional<int> code = cli::parse(*app, argc, argv)) return code;
  try {
    if (!rate.empty()) o.rate = parse_rate(rate);
    if (!domain.empty()) o.domain_id = static_cast<int>(parse_int("--domain", domain, 0, 101));
    if (!max_restarts.empty()) a.max_restarts = static_cast<int>(parse_int("--max-restarts", max_restarts, 0, 1000));
    if (!stop_timeout.empty()) {
      a.timing.stop_timeout = std::chrono::milliseconds(parse_int("--stop-timeout-ms", stop_timeout, 1, 600'000));
    }
    if (!settle.empty()) a.timing.settle = std::chrono::milliseconds(parse_int("--settle-ms", settle, 0, 600'000));
    for (const std::string& set : o.overrides) {
      if (set.find('=') == std::string::npos) throw ArgumentError("--set: '" + set + "' is not key=value");
    }
    // First, so that a --set of the same key wins (as with the other tools); quoted: a string.
    if (system) o.overrides.insert(o.overrides.begin(), "transport.system_name=\"" + *system + "\"");
  } catch (const ArgumentError& e) {
    return cli::usage_error(*app, e.what());
  }
  return std::nullopt;
}

void check_paths(const launch::LaunchPlan& plan, const launch::LaunchOptions& options) {
  namespace fs = std::filesystem;
  if (!fs::is_regular_file(options.config_file)) throw ArgumentError("config file '" + options.config_file + "' not found");
  if (!fs::exists(options.input)) throw ArgumentError("input '" + options.input + "' not found");
  for (const auto& s : plan.services) {
    if (::access(s.argv.front().c_str(), X_OK) != 0) {
      throw ArgumentError("service binary '" + s.argv.front() + "' is missing or not executable (see --bin-dir)");
    }
  }
}

}  // namespace fuse::launch_tool

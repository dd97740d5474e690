#include "arguments.hpp"

#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>

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

Arguments parse_arguments(const std::vector<std::string>& args) {
  Arguments a;
  launch::LaunchOptions& o = a.launch;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    auto value = [&]() -> const std::string& {
      if (i + 1 >= args.size()) throw ArgumentError(arg + " needs a value");
      return args[++i];
    };
    if (arg == "--help" || arg == "-h") {
      a.help = true;
    } else if (arg == "--config") {
      o.config_file = value();
    } else if (arg == "--input") {
      o.input = value();
    } else if (arg == "--mode") {
      o.mode = value();
      if (o.mode != "lockstep" && o.mode != "realtime") throw ArgumentError("--mode: '" + o.mode + "' is not lockstep or realtime");
    } else if (arg == "--rate") {
      o.rate = parse_rate(value());
    } else if (arg == "--out") {
      o.out_dir = value();
    } else if (arg == "--map-dir") {
      o.map_dir = value();
    } else if (arg == "--domain") {
      o.domain_id = static_cast<int>(parse_int(arg, value(), 0, 101));
    } else if (arg == "--vendor") {
      o.vendor = value();
      if (o.vendor != "fastdds" && o.vendor != "cyclonedds") throw ArgumentError("--vendor: '" + o.vendor + "' is not fastdds or cyclonedds");
    } else if (arg == "--set") {
      o.overrides.push_back(value());
      if (o.overrides.back().find('=') == std::string::npos) throw ArgumentError("--set: '" + o.overrides.back() + "' is not key=value");
    } else if (arg == "--bin-dir") {
      o.bin_dir = value();
    } else if (arg == "--restart") {
      o.restart = true;
    } else if (arg == "--max-restarts") {
      a.max_restarts = static_cast<int>(parse_int(arg, value(), 0, 1000));
    } else if (arg == "--stop-timeout-ms") {
      a.timing.stop_timeout = std::chrono::milliseconds(parse_int(arg, value(), 1, 600'000));
    } else if (arg == "--settle-ms") {
      a.timing.settle = std::chrono::milliseconds(parse_int(arg, value(), 0, 600'000));
    } else {
      throw ArgumentError("unknown argument '" + arg + "'");
    }
  }
  if (!a.help && (o.config_file.empty() || o.input.empty())) throw ArgumentError("--config and --input are required");
  return a;
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

std::string usage() {
  return "usage: fuse-launch --config FILE --input PATH [--mode lockstep|realtime] [--rate R] [--out DIR]\n"
         "                   [--map-dir DIR] [--domain N] [--vendor fastdds|cyclonedds] [--set key=value]...\n"
         "                   [--bin-dir DIR] [--restart] [--max-restarts N] [--stop-timeout-ms N] [--settle-ms N]\n"
         "  Starts fuse-map, fuse-state, fuse-update, then fuse-ingest replaying PATH; when the replay is\n"
         "  done, stops the others (the last started first; SIGKILL after --stop-timeout-ms, default 5000).\n"
         "  --out:      logs/<service>.log, trajectory.tum, map/ (default: fuse_out)\n"
         "  --domain, --vendor, --set: passed to every service as --set overrides\n"
         "  --bin-dir:  where the service binaries are (default: the launcher's own directory)\n"
         "  --restart:  restart a service that dies unexpectedly (backoff 250 ms, doubling;\n"
         "              at most --max-restarts, default 5); fuse-ingest only in realtime mode\n"
         "  --settle-ms: pause between starting the services and fuse-ingest (default 500)\n"
         "  exit codes: 0 every service did its part and stopped cleanly, 1 a service failed, 2 usage\n";
}

}  // namespace fuse::launch_tool

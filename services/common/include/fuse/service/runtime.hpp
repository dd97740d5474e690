// What every service main shares: the command line (CLI11: --config FILE, --set key=value,
// --domain N, --vendor V, --log-level L, --help, --version, and the service's own options), the
// validated system config, logging, and shutdown on SIGINT/SIGTERM.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "fuse/service/system_config.hpp"
#include "fuse/transport/transport.hpp"

namespace fuse::service {

/// Exit codes of every service (supervisors restart on 1 and signals, never on 2 or 4: restarting
/// cannot fix them; the systemd units say RestartPreventExitStatus=2 4).
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;  ///< a runtime failure (restarting may help)
inline constexpr int kExitUsage = 2;    ///< usage or config error
inline constexpr int kExitInput = 4;    ///< an input (recording, sensor, calibration file) that cannot be read

struct ServiceArgs {
  std::string config_file;
  std::vector<std::string> overrides;
  std::map<std::string, std::string> options;  ///< the service's own --name value options
  std::string log_level = "info";
  std::string get(const std::string& name, const std::string& fallback = "") const {
    auto it = options.find(name);
    return it == options.end() ? fallback : it->second;
  }
};

/// One of a service's own options: --name VALUE.
struct OptionSpec {
  std::string name;        ///< without "--"
  std::string value_name;  ///< e.g. "DIR", shown in --help
  std::string help;
};

/// What --help says about a service, and the options it takes besides the common ones.
struct ServiceCli {
  std::string name;         ///< the binary, e.g. "fuse-map"
  std::string description;  ///< the first paragraph of --help
  std::vector<OptionSpec> options;
  std::string footer;       ///< after the options (exit codes, notes)
};

/// Parses argv. Returns the exit code when the program should end now: 0 after --help or
/// --version (printed on stdout), kExitUsage after a usage error (printed on stderr, naming the
/// flag); std::nullopt to go on. --domain N and --vendor V become the overrides
/// transport.domain_id=N and transport.vendor=V, applied before the --set ones.
std::optional<int> parse_args(const ServiceCli& cli, int argc, char** argv, ServiceArgs& args);

/// Blocks SIGINT/SIGTERM in every thread (call first in main, before any thread starts);
/// stop_requested() turns true once one arrives.
void install_signal_handling();
bool stop_requested();
/// Sleeps up to `seconds`, returning early (true) when a stop was requested.
bool wait_for_stop(double seconds);

/// The usual main body: parse, load config, set up logging; on error prints the reason and
/// returns the exit code (2 for usage/config) through `exit_code`.
bool start_service(const ServiceCli& cli, int argc, char** argv, ServiceArgs& args, SystemConfig& config,
                   int& exit_code);

}  // namespace fuse::service

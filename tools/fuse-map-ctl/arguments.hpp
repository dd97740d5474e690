// Command line of fuse-map-ctl, and the transport settings it joins the services with.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "fuse/transport/transport.hpp"

namespace fuse::map_ctl {

/// A command line that cannot be used; main prints it with the usage and exits with 2.
class ArgumentError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class Command { kNone, kStats, kSetMode, kSave, kLoad };

struct Arguments {
  Command command = Command::kNone;
  std::string mode;  ///< --mode: mapping | localization
  std::string file;  ///< save [FILE] / load FILE, made absolute (fuse-map runs elsewhere)
  std::string config_file;             ///< optional: its `transport:` section
  std::vector<std::string> overrides;  ///< --set dotted.key=value in order, then --domain, --vendor
  int deadline_ms = 5000;
  bool json = false;
  bool help = false;
};

/// Parses argv[1..]; throws ArgumentError naming the offending argument.
Arguments parse_arguments(const std::vector<std::string>& args);

/// The --help text.
std::string usage();

/// The `transport:` section of `file` (none: the defaults, domain 0) with the overrides applied;
/// the file's other sections are not read. Throws fuse::ConfigError.
transport::TransportConfig load_transport_config(const std::string& file, const std::vector<std::string>& overrides);

}  // namespace fuse::map_ctl

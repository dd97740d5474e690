// Command line of fuse-query.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace fuse::query_tool {

/// A command line that cannot be used; main prints it with the usage and exits with 2.
class ArgumentError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Arguments {
  bool latest = true;  ///< --latest (the default) or --time T
  double time = 0.0;
  bool json = false;
  int deadline_ms = 1000;
  std::string config_file;             ///< optional: its `transport:` section
  std::vector<std::string> overrides;  ///< --set dotted.key=value, in order
  bool help = false;
};

/// Parses argv[1..]; throws ArgumentError naming the offending argument.
Arguments parse_arguments(const std::vector<std::string>& args);

/// The --help text.
std::string usage();

}  // namespace fuse::query_tool

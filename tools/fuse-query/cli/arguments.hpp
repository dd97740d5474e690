// Command line of fuse-query (CLI11, the convention of every binary: fuse/cli/cli.hpp).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "fuse/query/client.hpp"

namespace fuse::query_tool {

struct Arguments {
  bool latest = true;  ///< --latest (the default) or --time T
  double time = 0.0;
  query::Clock clock = query::Clock::sensor;  ///< --clock: the clock --time is on
  bool json = false;
  int deadline_ms = 1000;
  std::string config_file;             ///< optional: its `transport:` section
  std::vector<std::string> overrides;  ///< --domain, --vendor, then --set dotted.key=value, in order
};

/// Parses and checks argv into `a`. std::nullopt: go on; otherwise the exit code to end with
/// (0 after --help / --version, 2 after a usage error, printed naming the flag).
std::optional<int> parse_arguments(int argc, char** argv, Arguments& a);

}  // namespace fuse::query_tool

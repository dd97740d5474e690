// Command line of fuse-launch.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "fuse/launch/launch_plan.hpp"
#include "fuse/launch/launcher.hpp"

namespace fuse::launch_tool {

/// A command line that cannot be used; main prints it with the usage and exits with 2.
class ArgumentError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Arguments {
  launch::LaunchOptions launch;  ///< bin_dir empty: the launcher's own directory
  launch::LaunchTiming timing;
  int max_restarts = 5;
};

/// Parses and checks argv into `a` (CLI11, the convention of every binary: fuse/cli/cli.hpp).
/// std::nullopt: go on; otherwise the exit code to end with (0 after --help / --version, 2 after
/// a usage error, printed naming the flag).
std::optional<int> parse_arguments(int argc, char** argv, Arguments& a);

/// Refuses what would fail only after the services started: a missing config, input or binary.
void check_paths(const launch::LaunchPlan& plan, const launch::LaunchOptions& options);


}  // namespace fuse::launch_tool

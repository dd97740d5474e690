// Command line of fuse-launch.
#pragma once

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
  bool help = false;
};

/// Parses argv[1..]; throws ArgumentError naming the offending argument.
Arguments parse_arguments(const std::vector<std::string>& args);

/// Refuses what would fail only after the services started: a missing config, input or binary.
void check_paths(const launch::LaunchPlan& plan, const launch::LaunchOptions& options);

/// The --help text.
std::string usage();

}  // namespace fuse::launch_tool

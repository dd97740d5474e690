// Command line of fuse-sim (see tools/fuse-sim/src/main.cpp for the synopsis).
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "fuse/sim/simulator.hpp"

namespace fuse::sim {

/// A bad command line (the tool exits with code 2).
class CliError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct CliCommand {
  bool help = false;
  SimOptions options;
};

/// Parses the arguments (without the program name). Throws CliError naming what was wrong.
CliCommand parse_cli(const std::vector<std::string>& args);
std::string usage();

}  // namespace fuse::sim

// Command line of fuse-sim (CLI11, the convention of every binary: fuse/cli/cli.hpp; see
// tools/fuse-sim/src/main.cpp for the synopsis).
#pragma once

#include <optional>

#include "fuse/sim/simulator.hpp"

namespace fuse::sim {

/// Parses and checks argv into `options`. std::nullopt: go on; otherwise the exit code to end
/// with (0 after --help / --version, 2 after a usage error, printed naming the flag).
std::optional<int> parse_arguments(int argc, char** argv, SimOptions& options);

}  // namespace fuse::sim

// Command line of fuse-import (CLI11, the convention of every binary: fuse/cli/cli.hpp).
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <string>

#include "importer.hpp"

namespace fuse::import {

struct Arguments {
  std::string input;  ///< --input: .bag, rosbag2 directory, .db3 or .mcap
  std::string out;    ///< --out: the recording to write
  ImportConfig import;
  std::optional<Eigen::Isometry3d> T_imu_lidar;  ///< --extrinsic: stored as the recording's calibration
};

/// Parses and checks argv into `a` before the bag is opened. std::nullopt: go on; otherwise the
/// exit code to end with (0 after --help / --version, 2 after a usage error, printed naming the flag).
std::optional<int> parse_arguments(int argc, char** argv, Arguments& a);

}  // namespace fuse::import

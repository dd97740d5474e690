// Command line of fuse-import.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "importer.hpp"

namespace fuse::import {

/// A command line that cannot be used; main prints it with the usage and exits with 2.
class ArgumentError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Arguments {
  std::string input;  ///< --input: .bag, rosbag2 directory, .db3 or .mcap
  std::string out;    ///< --out: the recording to write
  ImportConfig import;
  std::optional<Eigen::Isometry3d> T_imu_lidar;  ///< --extrinsic: stored as the recording's calibration
  bool help = false;
};

/// Parses argv[1..]; throws ArgumentError naming the offending argument.
Arguments parse_arguments(const std::vector<std::string>& args);

std::string usage();

}  // namespace fuse::import

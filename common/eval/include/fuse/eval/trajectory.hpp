// Trajectory files: TUM ("t x y z qx qy qz qw") and KITTI (3x4 row-major pose per line).
#pragma once

#include <string>
#include <vector>

#include "fuse/core/types.hpp"

namespace fuse::eval {

using Trajectory = std::vector<StampedPose>;

/// Reads a TUM file; '#' comment lines are skipped. Throws std::runtime_error naming the line.
Trajectory read_tum(const std::string& path);
/// Reads a KITTI pose file; timestamps are the line index unless a times file is given.
Trajectory read_kitti(const std::string& path, const std::string& times_path = "");
/// Writes TUM with 9 decimals for time and position.
void write_tum(const std::string& path, const Trajectory& trajectory);

}  // namespace fuse::eval

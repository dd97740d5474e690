// Trajectory files: TUM ("t x y z qx qy qz qw") and KITTI (3x4 row-major pose per line).
#pragma once

#include <string>
#include <vector>

#include "fuse/core/types.hpp"

namespace fuse::eval {

using Trajectory = std::vector<StampedPose>;

/// Reads a TUM file; '#' comment lines are skipped. Throws std::runtime_error naming the line.
///
/// Every line is checked: 8 columns, numbers only, finite values, a unit quaternion (normalised
/// when within kUnitQuaternionTolerance of unit norm, an error otherwise) and timestamps that do
/// not decrease. A repeated timestamp keeps the first pose and drops the later one with a warning
/// (real ground truth files have them; evo's nearest-stamp matching also picks the first).
Trajectory read_tum(const std::string& path);
/// Reads a KITTI pose file; timestamps are the line index unless a times file is given.
///
/// Every line needs 12 finite numbers whose rotation block is orthonormal with det +1 within
/// kRotationTolerance (it is then projected onto SO(3)). A times file needs one finite,
/// increasing timestamp per pose line.
Trajectory read_kitti(const std::string& path, const std::string& times_path = "");
/// Writes TUM with 9 decimals for time and position.
void write_tum(const std::string& path, const Trajectory& trajectory);

/// File formats the evaluation tools understand.
enum class TrajectoryFormat { kTum, kKitti };
/// Parses "tum" / "kitti"; throws std::invalid_argument on anything else.
TrajectoryFormat parse_trajectory_format(const std::string& name);
/// Reads a file of the given format (KITTI without a times file).
Trajectory read_trajectory(const std::string& path, TrajectoryFormat format);

/// |‖q‖ - 1| up to which a TUM quaternion counts as unit and is normalised: covers files that
/// print quaternions with 3 or more decimals.
inline constexpr double kUnitQuaternionTolerance = 5e-3;
/// Largest |(RᵀR - I)_ij| and |det R - 1| accepted for a KITTI rotation block: covers rotations
/// printed with 4 or more significant digits.
inline constexpr double kRotationTolerance = 5e-3;

}  // namespace fuse::eval

// Matching an estimated trajectory to its reference, as evo's sync.associate_trajectories
// (timestamps) or pose by pose (KITTI files, which have no timestamps).
#pragma once

#include "fuse/eval/trajectory.hpp"

namespace fuse::eval {

/// evo's default --t_max_diff: largest |t_ref - t_est| (s) of an accepted match.
inline constexpr double kDefaultMaxTimeDifference = 0.01;

/// Two trajectories of equal length whose i-th poses belong together.
struct AssociatedTrajectories {
  Trajectory reference;
  Trajectory estimate;
};

/// evo sync.associate_trajectories (offset 0): every pose of the shorter trajectory is matched to
/// the pose of the longer one nearest in time (the first on a tie), kept when the difference is
/// at most max_time_difference. Throws std::runtime_error when nothing matches and
/// std::invalid_argument when timestamps do not increase.
AssociatedTrajectories associate_by_time(const Trajectory& reference, const Trajectory& estimate,
                                         double max_time_difference = kDefaultMaxTimeDifference);

/// Pose i with pose i; both trajectories must have the same length (as evo for KITTI files),
/// else std::runtime_error naming both lengths.
AssociatedTrajectories associate_by_index(const Trajectory& reference, const Trajectory& estimate);

}  // namespace fuse::eval

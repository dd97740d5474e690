// Trajectory association by nearest timestamp (evo sync.associate_trajectories) or by index.
#include "fuse/eval/association.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "fuse/core/logging.hpp"

namespace fuse::eval {
namespace {

/// Index of the stamp of `sorted` nearest to t; the first one on a tie (numpy argmin).
/// `sorted` is non-empty and increasing, so only the two neighbours of t need checking.
std::size_t nearest_index(const Trajectory& sorted, double t) {
  const auto after = std::lower_bound(sorted.begin(), sorted.end(), t,
                                      [](const StampedPose& pose, double stamp) { return pose.t < stamp; });
  if (after == sorted.begin()) return 0;
  if (after == sorted.end()) return sorted.size() - 1;
  const auto before = after - 1;
  // <= keeps the earlier pose on an exact tie, as argmin returns the first minimum.
  return std::abs(before->t - t) <= std::abs(after->t - t) ? static_cast<std::size_t>(before - sorted.begin())
                                                           : static_cast<std::size_t>(after - sorted.begin());
}

/// The nearest-stamp search needs increasing timestamps (the readers guarantee them).
void require_increasing(const Trajectory& trajectory, const std::string& name) {
  for (std::size_t i = 1; i < trajectory.size(); ++i) {
    if (!(trajectory[i].t > trajectory[i - 1].t)) {
      throw std::invalid_argument(name + " timestamps are not increasing at pose " + std::to_string(i));
    }
  }
}

}  // namespace

AssociatedTrajectories associate_by_time(const Trajectory& reference, const Trajectory& estimate,
                                         double max_time_difference) {
  if (!(max_time_difference >= 0.0) || !std::isfinite(max_time_difference)) {
    throw std::invalid_argument("max time difference must be a finite number >= 0, got " +
                                std::to_string(max_time_difference));
  }
  if (reference.empty() || estimate.empty()) throw std::runtime_error("cannot associate an empty trajectory");
  require_increasing(reference, "reference");
  require_increasing(estimate, "estimate");

  // evo iterates over the shorter trajectory and searches the longer one (reference on a tie).
  const bool estimate_longer = estimate.size() > reference.size();
  const Trajectory& shorter = estimate_longer ? reference : estimate;
  const Trajectory& longer = estimate_longer ? estimate : reference;

  AssociatedTrajectories out;
  for (const StampedPose& pose : shorter) {
    const StampedPose& match = longer[nearest_index(longer, pose.t)];
    if (std::abs(match.t - pose.t) > max_time_difference) continue;
    out.reference.push_back(estimate_longer ? pose : match);
    out.estimate.push_back(estimate_longer ? match : pose);
  }
  if (out.reference.empty()) {
    throw std::runtime_error("no matching timestamps between reference and estimate with max. time difference " +
                             std::to_string(max_time_difference) + " s");
  }
  logger("eval")->debug("associated {} of max. {} poses (max. time difference {} s)", out.reference.size(),
                        shorter.size(), max_time_difference);
  return out;
}

AssociatedTrajectories associate_by_index(const Trajectory& reference, const Trajectory& estimate) {
  if (reference.size() != estimate.size()) {
    throw std::runtime_error("index association needs equal lengths: reference has " +
                             std::to_string(reference.size()) + " poses, estimate has " +
                             std::to_string(estimate.size()));
  }
  if (reference.empty()) throw std::runtime_error("cannot associate an empty trajectory");
  return {reference, estimate};
}

}  // namespace fuse::eval

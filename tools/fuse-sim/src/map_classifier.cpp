#include "fuse/sim/map_classifier.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "fuse/eval/alignment.hpp"
#include "fuse/eval/trajectory.hpp"
#include "fuse/sim/cloud_reader.hpp"
#include "fuse/sim/scenario.hpp"

namespace fuse::sim {

MapClassification classify_points(const std::vector<Eigen::Vector3f>& points, const World& statics, const World& swept,
                                  double tolerance) {
  MapClassification c;
  c.map_points = points.size();
  for (const Eigen::Vector3f& pf : points) {
    const Eigen::Vector3d p = pf.cast<double>();
    if (std::isfinite(statics.clearance_within(p, tolerance)))
      ++c.static_points;
    else if (std::isfinite(swept.clearance_within(p, tolerance)))
      ++c.ghost_points;
    else
      ++c.other_points;
  }
  return c;
}

namespace {
/// Moves the points from the estimate's map frame into the world: the rigid transform that best
/// aligns the estimate's positions onto the true ones at the same times (Umeyama, no scale).
void move_into_world(std::vector<Eigen::Vector3f>& points, const std::string& estimate_file, const Trajectory& truth) {
  eval::Trajectory estimate;
  try {
    estimate = eval::read_tum(estimate_file);
  } catch (const std::exception& e) {  // an input that cannot be read, like the map itself
    throw CloudReadError("--map-trajectory: " + std::string(e.what()));
  }
  Eigen::Matrix3Xd est(3, static_cast<Eigen::Index>(estimate.size())), ref(3, static_cast<Eigen::Index>(estimate.size()));
  Eigen::Index n = 0;
  for (const StampedPose& pose : estimate) {
    if (pose.t < truth.t_begin() || pose.t > truth.t_end()) continue;
    est.col(n) = pose.p;
    ref.col(n) = truth.state(pose.t).p;
    ++n;
  }
  if (n < 3) throw std::runtime_error("--map-trajectory: fewer than 3 poses of " + estimate_file + " lie within the run");
  const eval::Similarity3 T = eval::umeyama_alignment(est.leftCols(n), ref.leftCols(n), false);
  const Eigen::Matrix3f R = T.rotation.cast<float>();
  const Eigen::Vector3f t = T.translation.cast<float>();
  for (Eigen::Vector3f& p : points) p = R * p + t;
}
}  // namespace

MapClassification classify_map_file(const SimOptions& o) {
  std::vector<Eigen::Vector3f> points = read_cloud(o.classify_map);
  const Scenario sc = make_scenario(o.scenario, o.world_seed, o.seed, kStartTime, o.laps, o.start_at_m, o.traffic, o.stops);
  const Trajectory& tr = *sc.trajectory;
  if (!o.map_trajectory.empty()) move_into_world(points, o.map_trajectory, tr);
  const double duration = o.duration_s ? std::min(*o.duration_s, tr.t_end() - tr.t_begin()) : tr.t_end() - tr.t_begin();
  World swept;
  if (sc.traffic)
    for (const Box& b : sc.traffic->swept_volume(tr.t_begin(), tr.t_begin() + duration)) swept.add(b);
  swept.build();
  return classify_points(points, sc.world, swept, o.classify_tolerance_m);
}

}  // namespace fuse::sim

#include "fuse/sim/map_classifier.hpp"

#include <algorithm>
#include <cmath>

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

MapClassification classify_map_file(const SimOptions& o) {
  const std::vector<Eigen::Vector3f> points = read_cloud(o.classify_map);
  const Scenario sc = make_scenario(o.scenario, o.world_seed, o.seed, kStartTime, o.laps, o.start_at_m, o.traffic);
  const Trajectory& tr = *sc.trajectory;
  const double duration = o.duration_s ? std::min(*o.duration_s, tr.t_end() - tr.t_begin()) : tr.t_end() - tr.t_begin();
  World swept;
  if (sc.traffic)
    for (const Box& b : sc.traffic->swept_volume(tr.t_begin(), tr.t_begin() + duration)) swept.add(b);
  swept.build();
  return classify_points(points, sc.world, swept, o.classify_tolerance_m);
}

}  // namespace fuse::sim

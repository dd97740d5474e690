// Judging an estimator's map against the simulated world (fuse-sim --classify-map). Each map point is
//  - static: within the tolerance of a static surface (the distance to the nearest solid, box or
//    plane, as World::clearance: 0 inside a box; found through the BVH, so a million points take
//    about a second);
//  - ghost: not static, but within the tolerance of the volume some moving object swept during the
//    run (Traffic::swept_volume): a moving object smeared into the map;
//  - other: neither (drift, noise, points of nothing).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "fuse/sim/simulator.hpp"
#include "fuse/sim/world.hpp"

namespace fuse::sim {

struct MapClassification {
  std::size_t map_points = 0, static_points = 0, ghost_points = 0, other_points = 0;
};

/// Classifies the points against the static world and the movers' swept volume (both built).
MapClassification classify_points(const std::vector<Eigen::Vector3f>& points, const World& statics, const World& swept,
                                  double tolerance);

/// Rebuilds the scenario of `options` (same world, trajectory and traffic as the run with these
/// arguments), reads options.classify_map (CloudReadError when it cannot) and classifies it; the
/// movers' volume is the one swept over the run's duration (the whole scenario, or --duration).
MapClassification classify_map_file(const SimOptions& options);

}  // namespace fuse::sim

// Traffic on a street grid (the "urban" scenario): cars circling rectangles of streets in their
// lanes (right-hand traffic, both directions, 5-15 m/s) and pedestrians walking round a block on
// its sidewalks or round a loop that crosses a street at two crosswalks (1-2 m/s). Every mover is
// drawn from the traffic stream of the world seed; a draw whose box would come near the platform
// (a car-sized footprint around the ego trajectory, checked every 20 ms with a margin) gets a new
// start along its loop, and after a few tries is drawn again from scratch. The movers therefore
// keep clear of the ego vehicle at all times (and meet it only as oncoming or crossing traffic).
// Movers are wanted where the sensor can see them: a draw whose loop never comes within
// `route_reach` of the platform's path is drawn again.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "fuse/sim/random.hpp"
#include "fuse/sim/traffic.hpp"
#include "fuse/sim/trajectory.hpp"

namespace fuse::sim {

/// The streets: centre lines x = x_lines[i] (streets along y) and y = y_lines[j] (along x),
/// ascending, and the cross-section measured from a centre line.
struct StreetGrid {
  std::vector<double> x_lines, y_lines;
  double inner_lane = 1.75, outer_lane = 5.25;  ///< lane centre lines (both sides of the street)
  double walk_min = 11.4, walk_max = 12.2;      ///< pedestrians walk this far from the centre line
  double crosswalk_setback = 15.0;              ///< crosswalks this far from the crossing street's centre line
};

struct TrafficConfig {
  int cars = 120, pedestrians = 150;
  double car_speed_min = 5.0, car_speed_max = 15.0;
  double pedestrian_speed_min = 1.0, pedestrian_speed_max = 2.0;
  int max_loop_blocks = 2;      ///< a car's rectangle spans 1 to this many blocks each way
  double route_reach = 12.0;    ///< a loop must pass this close to the platform's path (0: anywhere)
  double crossing_share = 0.5;  ///< share of pedestrians whose loop crosses a street
  double car_length = 4.5, car_width = 1.8, car_height = 1.5;
  double pedestrian_size = 0.5, pedestrian_height = 1.7;
  // The platform's footprint (centred on the IMU, along its heading) and the clearance kept.
  double ego_length = 4.6, ego_width = 1.9, clearance = 0.5;
  double check_period_s = 0.02;  ///< how often the clearance is checked along the ego trajectory
};

/// What populating the streets took.
struct TrafficStats {
  int cars = 0, pedestrians = 0;
  int redraws = 0;    ///< draws that came near the platform and were moved or replaced
  int off_route = 0;  ///< draws replaced because their loop stays away from the platform's path
  int dropped = 0;    ///< movers given up after too many draws
};

/// Closed loop through `loop`'s corners (axis-aligned, travel order) moved `right` metres to the
/// right of the direction of travel (a lane or sidewalk line of a street loop).
std::vector<Eigen::Vector2d> offset_loop(const std::vector<Eigen::Vector2d>& loop, double right);

/// Whether mover i's box comes within `clearance` of the ego footprint at time t (separating axes
/// of the ego rectangle, turned with the heading, and the axis-aligned box).
bool near_ego(const Traffic& traffic, std::size_t i, const TrajectoryState& ego, double t, const TrafficConfig& config,
              double clearance);

/// Cars and pedestrians on the grid, clear of the ego trajectory over its whole duration.
Traffic populate_streets(const StreetGrid& grid, const TrafficConfig& config, const Trajectory& ego, Rng& rng,
                         TrafficStats& stats);

}  // namespace fuse::sim

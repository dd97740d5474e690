// Internal: one builder per scenario (scenario_<name>.cpp) and shared world-building helpers.
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "fuse/sim/random.hpp"
#include "fuse/sim/scenario.hpp"

namespace fuse::sim::detail {

/// Surface ids written into intensities' materials (stable across scenarios).
enum SurfaceId : std::uint16_t {
  kFloor = 1,
  kCeiling = 2,
  kWall = 3,
  kJamb = 4,
  kRecess = 5,
  kFurniture = 6,
  kBuilding = 7,
  kGround = 8,
  kStep = 9,
  kPole = 10,
  kCar = 11,
  kTree = 12,
  kMovingCar = 13,
  kPedestrian = 14,
};

/// A material with reflectivity `base` +- `jitter` drawn from the world stream.
Material material(Rng& rng, SurfaceId id, double base, double jitter = 0.05);
/// Adds the box spanning the two corners (any order).
void add_box(World& world, const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Material& m);

/// laps: times round the loop (a longer walk through the same world, e.g. for a soak test).
void build_corridor(Scenario& s, Rng& world_rng, Rng& motion_rng, double t0, int laps = 1);
void build_stairs(Scenario& s, Rng& world_rng, Rng& motion_rng, double t0);
void build_room(Scenario& s, Rng& world_rng, Rng& motion_rng, double t0);
void build_campus(Scenario& s, Rng& world_rng, Rng& motion_rng, double t0);
void build_urban(Scenario& s, Rng& world_rng, Rng& motion_rng, double t0);

}  // namespace fuse::sim::detail

// Scenario "stairs": a switchback stairwell over four levels (three floors climbed). Each floor
// has a flight up along y in [0, 1.8] to a mid landing, a U-turn around the central wall and a
// second flight back along y in [2.2, 4] to the next floor landing. Door recesses and pipes on
// the walls are placed by the world seed. Sustained 3-D motion: about 50 m climbing 9 m.
#include <string>

#include "fuse/sim/motion_profiles.hpp"
#include "scenario_builders.hpp"

namespace fuse::sim::detail {

namespace {
constexpr int kFloorsClimbed = 3;
constexpr double kFloorHeight = 3.0;
constexpr double kLandingX = 2.0;               // floor landings x in [0, 2]
constexpr double kFlightEndX = 6.0;             // flights x in [2, 6]
constexpr double kWellX = 8.0, kWellY = 4.0;    // stairwell interior
constexpr double kFlightWidth = 1.8;            // flight A y in [0, 1.8], B in [2.2, 4]
constexpr int kStepsPerFlight = 9;
constexpr double kSlab = 0.2, kWallThickness = 0.2, kStepThickness = 0.15;
constexpr double kCarryHeight = 1.3;            // sensor above the walking surface
constexpr double kLaneA = 0.9, kLaneB = 3.1;    // walking lines (y) of the two flights
constexpr double kTurnX = 7.0, kTurnBackX = 1.0;
constexpr double kTurnRadius = 0.6, kBendRadius = 1.5;  // horizontal corners, slope bends
constexpr double kDoorDepth = 0.05, kDoorHeight = 2.1;
constexpr double kRateMin = 0.7, kRateMax = 0.9;

void add_flight(World& world, Rng& rng, double z0, bool forward) {
  const double run = (kFlightEndX - kLandingX) / kStepsPerFlight;
  const double rise = 0.5 * kFloorHeight / kStepsPerFlight;
  const double y0 = forward ? 0.0 : kWellY - kFlightWidth, y1 = forward ? kFlightWidth : kWellY;
  const Material m = material(rng, kStep, 0.45);
  for (int j = 0; j < kStepsPerFlight; ++j) {
    const double x0 = forward ? kLandingX + j * run : kFlightEndX - (j + 1) * run;
    const double top = z0 + (j + 1) * rise;
    add_box(world, {x0, y0, top - rise - kStepThickness}, {x0 + run, y1, top}, m);
  }
}
}  // namespace

void build_stairs(Scenario& s, Rng& rng, Rng& motion_rng, double t0) {
  const int levels = kFloorsClimbed + 1;
  const double top = levels * kFloorHeight, t = kWallThickness;
  const Material wall = material(rng, kWall, 0.6), floor = material(rng, kFloor, 0.35);
  // Enclosure, ground and roof.
  add_box(s.world, {-t, -t, -2 * kSlab}, {kWellX + t, kWellY + t, -kSlab}, floor);
  add_box(s.world, {-t, -t, top}, {kWellX + t, kWellY + t, top + kSlab}, material(rng, kCeiling, 0.7));
  add_box(s.world, {-t, -t, -2 * kSlab}, {0.0, kWellY + t, top}, wall);
  add_box(s.world, {kWellX, -t, -2 * kSlab}, {kWellX + t, kWellY + t, top}, wall);
  add_box(s.world, {0.0, -t, -2 * kSlab}, {kWellX, 0.0, top}, wall);
  add_box(s.world, {0.0, kWellY, -2 * kSlab}, {kWellX, kWellY + t, top}, wall);
  // Central wall between the flights.
  add_box(s.world, {kLandingX, kFlightWidth, -2 * kSlab}, {kFlightEndX, kWellY - kFlightWidth, top}, wall);
  int features = 0;
  for (int n = 0; n < levels; ++n) {
    const double z = n * kFloorHeight;
    add_box(s.world, {0.0, 0.0, z - kSlab}, {kLandingX, kWellY, z}, floor);  // floor landing
    // A door (panel and frame standing 5 cm proud of the x = 0 wall) on every floor landing.
    const double door_y = rng.uniform(0.8, kWellY - 1.8), door_w = rng.uniform(0.9, 1.2);
    add_box(s.world, {0.0, door_y, z}, {kDoorDepth, door_y + door_w, z + kDoorHeight}, material(rng, kJamb, 0.4));
    ++features;
    if (n + 1 < levels) {
      add_box(s.world, {kFlightEndX, 0.0, z + 0.5 * kFloorHeight - kSlab},
              {kWellX, kWellY, z + 0.5 * kFloorHeight}, floor);  // mid landing
      add_flight(s.world, rng, z, true);
      add_flight(s.world, rng, z + 0.5 * kFloorHeight, false);
    }
    // A vertical pipe in a seeded corner of the mid landing side.
    if (rng.uniform() < 0.7) {
      const double py = rng.uniform() < 0.5 ? 0.05 : kWellY - 0.2;
      add_box(s.world, {kWellX - 0.2, py, z}, {kWellX - 0.05, py + 0.15, z + kFloorHeight}, material(rng, kPole, 0.3));
      ++features;
    }
  }
  const double h = kCarryHeight, half = 0.5 * kFloorHeight;
  std::vector<Waypoint> w = {{{0.5, kLaneA, h}, 0.0}};
  for (int n = 0; n < kFloorsClimbed; ++n) {
    const double z = n * kFloorHeight + h;
    w.push_back({{kLandingX, kLaneA, z}, kBendRadius});
    w.push_back({{kFlightEndX, kLaneA, z + half}, kBendRadius});
    w.push_back({{kTurnX, kLaneA, z + half}, kTurnRadius});
    w.push_back({{kTurnX, kLaneB, z + half}, kTurnRadius});
    w.push_back({{kFlightEndX, kLaneB, z + half}, kBendRadius});
    w.push_back({{kLandingX, kLaneB, z + kFloorHeight}, kBendRadius});
    if (n + 1 < kFloorsClimbed) {
      w.push_back({{kTurnBackX, kLaneB, z + kFloorHeight}, kTurnRadius});
      w.push_back({{kTurnBackX, kLaneA, z + kFloorHeight}, kTurnRadius});
    }
  }
  w.push_back({{0.5, kLaneB, kFloorsClimbed * kFloorHeight + h}, 0.0});
  TimeLawConfig law;
  law.rate = motion_rng.uniform(kRateMin, kRateMax);
  const MotionConfig motion = walking_motion(motion_rng);
  s.trajectory.emplace(make_rounded_polyline(w), law, motion, t0);
  s.parameters = {{"floors_climbed", kFloorsClimbed}, {"floor_height_m", kFloorHeight},
                  {"steps_per_flight", kStepsPerFlight}, {"stairwell_x_m", kWellX},
                  {"stairwell_y_m", kWellY}, {"features", features}, {"walk_rate_mps", law.rate}};
}

}  // namespace fuse::sim::detail

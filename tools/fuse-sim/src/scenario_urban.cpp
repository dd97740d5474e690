// Scenario "urban": a street grid (6 x 5 streets, blocks 130 x 110 m) with continuous building
// frontages, and along the kerbs parked cars, street-light poles and trees (a trunk box and a
// crown box), all placed by the world seed; the streets carry traffic (street_traffic.hpp, built
// by make_scenario). A car with a roof-mounted sensor (1.9 m) drives a ~1.2 km L-shaped loop
// through six corners (five left, one right; radius 15 m) in the inner lane of right-hand traffic:
// 6-6.5 m/s through the corners, up to 16-18 m/s on the long straights (the scheduled time law),
// pitching and rolling on its suspension, and stops where it started (about 140 s).
//
// Street cross-section, from the centre line: inner lane 0-3.5 m, outer lane 3.5-7 m, parking
// 7-9 m, kerb at 9 m, sidewalk 9-13 m (poles at 9.3 m, trees at 10.5 m, pedestrians at
// 11.4-12.2 m), buildings from 13 m on. No kerb object within 20 m of a crossing (crosswalks at 15 m).
#include <algorithm>
#include <cmath>

#include "fuse/sim/imu_model.hpp"  // kDegToRad
#include "fuse/sim/street_traffic.hpp"
#include "scenario_builders.hpp"

namespace fuse::sim::detail {

namespace {
constexpr double kPitchX = 130.0, kPitchY = 110.0;  // street centre-line spacing
constexpr int kLinesX = 6, kLinesY = 5;             // street lines x = i * kPitchX, y = j * kPitchY
// Cross-section (metres from the centre line).
constexpr double kInnerLane = 1.75, kOuterLane = 5.25;  // lane centre lines
constexpr double kParkingNear = 7.1;                    // parked cars from here outwards ...
constexpr double kCarWidth = 1.8;                       // ... to 8.9 m
constexpr double kPoleOffset = 9.3, kPoleSize = 0.3;
constexpr double kTreeOffset = 10.5;  // trunk centre
constexpr double kWalkMin = 11.4, kWalkMax = 12.2;
constexpr double kBuildingLine = 13.0;
constexpr double kCrosswalkSetback = 15.0;
constexpr double kIntersectionClear = 20.0;  // no kerb object this close to a crossing's centre line
// Buildings along every block frontage.
constexpr double kFrontageMin = 12.0, kFrontageMax = 30.0, kFrontageGapMax = 6.0;
constexpr double kSetbackMax = 2.5;
constexpr double kDepthMin = 12.0, kDepthMax = 24.0;
constexpr double kHeightMin = 6.0, kHeightMax = 35.0;
// Kerb objects: spacing and shares (the rest are trees).
constexpr double kKerbSpacingMin = 7.0, kKerbSpacingMax = 22.0;
constexpr double kParkedShare = 0.45, kPoleShare = 0.25;
constexpr double kParkedLengthMin = 4.0, kParkedLengthMax = 4.9;
constexpr double kParkedHeightMin = 1.4, kParkedHeightMax = 1.7;
constexpr double kPoleHeightMin = 5.0, kPoleHeightMax = 8.0;
constexpr double kTrunkMin = 0.3, kTrunkMax = 0.5;
constexpr double kCrownBaseMin = 2.6, kCrownBaseMax = 3.5;
constexpr double kCrownTopMin = 6.0, kCrownTopMax = 10.0;
constexpr double kCrownWidthMin = 2.5, kCrownWidthMax = 4.0;  // centred on the trunk: clear of the buildings
// The drive.
constexpr double kSensorHeight = 1.9;  // roof mount
constexpr double kCornerRadius = 15.0;
constexpr double kCornerRateMin = 6.0, kCornerRateMax = 6.5;        // m/s through the corners
constexpr double kStraightRateMin = 16.0, kStraightRateMax = 18.0;  // m/s at most on the straights
constexpr double kMaxAccelMin = 2.0, kMaxAccelMax = 2.5;            // m/s^2, braking and accelerating
constexpr double kBrakeLead = 8.0;  // the corner rate holds from this far before the arc ...
constexpr double kExitTrail = 4.0;  // ... to this far after it
// Suspension: a few tenths of a degree per m/s^2, body modes around 1.4 Hz.
constexpr double kPitchDegPerAccelMin = 0.30, kPitchDegPerAccelMax = 0.45;
constexpr double kRollDegPerAccelMin = 0.35, kRollDegPerAccelMax = 0.50;
constexpr double kBodyHzMin = 1.3, kBodyHzMax = 1.6;
constexpr double kDampingMin = 0.40, kDampingMax = 0.50;
// The route: street-line crossings (i, j), counter-clockwise; the car starts half way along the first side.
constexpr int kRoute[][2] = {{1, 1}, {4, 1}, {4, 2}, {3, 2}, {3, 3}, {1, 3}};

struct Counts {
  int buildings = 0, parked = 0, poles = 0, trees = 0;
};

// Buildings along one frontage of a block: from `lo` to `hi` along axis `along`, their street
// faces `setback` off the building line `line` on the across axis, extending in direction `into`.
void add_frontage(World& world, Rng& rng, int along, double lo, double hi, double line, double into, Counts& n) {
  for (double c = lo + rng.uniform(0.0, kFrontageGapMax); c + kFrontageMin <= hi;) {
    const double width = std::min(rng.uniform(kFrontageMin, kFrontageMax), hi - c);
    const double setback = rng.uniform(0.0, kSetbackMax), depth = rng.uniform(kDepthMin, kDepthMax);
    const double height = rng.uniform(kHeightMin, kHeightMax);
    Eigen::Vector3d a, b;
    a[along] = c;
    b[along] = c + width;
    a[1 - along] = line + into * setback;
    b[1 - along] = line + into * (setback + depth);
    a.z() = 0.0;
    b.z() = height;
    add_box(world, a, b, material(rng, kBuilding, 0.55, 0.2));
    ++n.buildings;
    c += width + rng.uniform(0.0, kFrontageGapMax);
  }
}

// A box whose across-axis extent is [near, far] from the centre line `line` on side `side`.
void add_kerb_box(World& world, int along, double a0, double a1, double line, double side, double near, double far,
                  double z0, double z1, const Material& m) {
  Eigen::Vector3d a, b;
  a[along] = a0;
  b[along] = a1;
  a[1 - along] = line + side * near;
  b[1 - along] = line + side * far;
  a.z() = z0;
  b.z() = z1;
  add_box(world, a, b, m);
}

// Parked cars, poles and trees along one side of a street segment between two crossings.
void add_kerb_objects(World& world, Rng& rng, int along, double line, double lo, double hi, double side, Counts& n) {
  for (double c = lo + kIntersectionClear + rng.uniform(0.0, kKerbSpacingMax); c < hi - kIntersectionClear;
       c += rng.uniform(kKerbSpacingMin, kKerbSpacingMax)) {
    const double kind = rng.uniform();
    if (kind < kParkedShare) {
      const double length = rng.uniform(kParkedLengthMin, kParkedLengthMax);
      const double height = rng.uniform(kParkedHeightMin, kParkedHeightMax);
      add_kerb_box(world, along, c, c + length, line, side, kParkingNear, kParkingNear + kCarWidth, 0.0, height,
                   material(rng, kCar, 0.6, 0.3));
      ++n.parked;
    } else if (kind < kParkedShare + kPoleShare) {
      const double height = rng.uniform(kPoleHeightMin, kPoleHeightMax);
      add_kerb_box(world, along, c, c + kPoleSize, line, side, kPoleOffset, kPoleOffset + kPoleSize, 0.0, height,
                   material(rng, kPole, 0.3));
      ++n.poles;
    } else {
      const double trunk = rng.uniform(kTrunkMin, kTrunkMax);
      const double base = rng.uniform(kCrownBaseMin, kCrownBaseMax), top = rng.uniform(kCrownTopMin, kCrownTopMax);
      const double crown = rng.uniform(kCrownWidthMin, kCrownWidthMax);
      const double mid = c + 0.5 * crown;  // the crown starts at c, the trunk stands under its centre
      add_kerb_box(world, along, mid - 0.5 * trunk, mid + 0.5 * trunk, line, side, kTreeOffset - 0.5 * trunk,
                   kTreeOffset + 0.5 * trunk, 0.0, base, material(rng, kTree, 0.35));
      add_kerb_box(world, along, c, c + crown, line, side, kTreeOffset - 0.5 * crown, kTreeOffset + 0.5 * crown, base,
                   top, material(rng, kTree, 0.45, 0.1));
      ++n.trees;
    }
  }
}

}  // namespace

void build_urban(Scenario& s, Rng& rng, Rng& motion_rng, double t0) {
  std::vector<double> xs, ys;
  for (int i = 0; i < kLinesX; ++i) xs.push_back(i * kPitchX);
  for (int j = 0; j < kLinesY; ++j) ys.push_back(j * kPitchY);
  Counts n;
  for (int i = 0; i + 1 < kLinesX; ++i)
    for (int j = 0; j + 1 < kLinesY; ++j) {
      const double x0 = xs[i] + kBuildingLine, x1 = xs[i + 1] - kBuildingLine;
      const double y0 = ys[j] + kBuildingLine, y1 = ys[j + 1] - kBuildingLine;
      add_frontage(s.world, rng, 0, x0, x1, y0, +1.0, n);  // facing the street y = ys[j]
      add_frontage(s.world, rng, 0, x0, x1, y1, -1.0, n);  // facing y = ys[j + 1]
      add_frontage(s.world, rng, 1, y0, y1, x0, +1.0, n);  // facing x = xs[i]
      add_frontage(s.world, rng, 1, y0, y1, x1, -1.0, n);  // facing x = xs[i + 1]
    }
  for (int i = 0; i < kLinesX; ++i)  // streets along y
    for (int j = 0; j + 1 < kLinesY; ++j)
      for (double side : {-1.0, 1.0}) add_kerb_objects(s.world, rng, 1, xs[i], ys[j], ys[j + 1], side, n);
  for (int j = 0; j < kLinesY; ++j)  // streets along x
    for (int i = 0; i + 1 < kLinesX; ++i)
      for (double side : {-1.0, 1.0}) add_kerb_objects(s.world, rng, 0, ys[j], xs[i], xs[i + 1], side, n);
  s.world.add(Plane{Eigen::Vector3d::UnitZ(), 0.0, material(rng, kGround, 0.3)});

  // The route in the inner lane: the loop through the crossings moved right of the travel direction.
  std::vector<Eigen::Vector2d> crossings;
  for (const auto& c : kRoute) crossings.emplace_back(xs[c[0]], ys[c[1]]);
  const std::vector<Eigen::Vector2d> lane = offset_loop(crossings, kInnerLane);
  const auto at_height = [](const Eigen::Vector2d& p) { return Eigen::Vector3d(p.x(), p.y(), kSensorHeight); };
  const Eigen::Vector3d start = at_height(0.5 * (lane[0] + lane[1]));
  std::vector<Waypoint> waypoints = {{start, 0.0}};
  for (std::size_t k = 1; k <= lane.size(); ++k) waypoints.push_back({at_height(lane[k % lane.size()]), kCornerRadius});
  waypoints.push_back({start, 0.0});
  std::vector<CornerSpan> corners;
  const Path path = make_rounded_polyline(waypoints, &corners);

  TimeLawConfig law;
  law.rate = motion_rng.uniform(kStraightRateMin, kStraightRateMax);
  const double corner_rate = motion_rng.uniform(kCornerRateMin, kCornerRateMax);
  law.max_accel = motion_rng.uniform(kMaxAccelMin, kMaxAccelMax);
  for (const CornerSpan& c : corners)
    law.limits.push_back({c.u_entry - kBrakeLead, c.u_exit + kExitTrail, corner_rate});
  MotionConfig motion;  // no sway or bob: the body moves on its suspension only
  motion.suspension.enabled = true;
  motion.suspension.pitch_per_accel = motion_rng.uniform(kPitchDegPerAccelMin, kPitchDegPerAccelMax) * kDegToRad;
  motion.suspension.roll_per_accel = motion_rng.uniform(kRollDegPerAccelMin, kRollDegPerAccelMax) * kDegToRad;
  motion.suspension.natural_hz = motion_rng.uniform(kBodyHzMin, kBodyHzMax);
  motion.suspension.damping_ratio = motion_rng.uniform(kDampingMin, kDampingMax);
  s.trajectory.emplace(path, law, motion, t0);
  s.vehicle_vibration = true;

  StreetGrid grid;
  grid.x_lines = xs;
  grid.y_lines = ys;
  grid.inner_lane = kInnerLane;
  grid.outer_lane = kOuterLane;
  grid.walk_min = kWalkMin;
  grid.walk_max = kWalkMax;
  grid.crosswalk_setback = kCrosswalkSetback;
  s.streets = grid;
  s.parameters = {{"block_pitch_x_m", kPitchX},
                  {"block_pitch_y_m", kPitchY},
                  {"streets_x", kLinesX},
                  {"streets_y", kLinesY},
                  {"buildings", n.buildings},
                  {"parked_cars", n.parked},
                  {"poles", n.poles},
                  {"trees", n.trees},
                  {"sensor_height_m", kSensorHeight},
                  {"corner_radius_m", kCornerRadius},
                  {"corner_rate_mps", corner_rate},
                  {"straight_rate_mps", law.rate},
                  {"max_accel_mps2", law.max_accel}};
}

}  // namespace fuse::sim::detail

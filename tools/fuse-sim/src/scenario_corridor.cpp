// Scenario "corridor": a closed rectangular loop of corridors (about 418 m of path), 2.4 m wide,
// 3 m tall, floor and ceiling planes, with sparse features every 8-20 m (door frames, recesses,
// pillars) placed by the world seed, so the along-corridor direction is only weakly observable.
// The walker starts and stops at the same pose in the middle of the first side.
#include <algorithm>

#include "fuse/sim/motion_profiles.hpp"
#include "scenario_builders.hpp"

namespace fuse::sim::detail {

namespace {

constexpr double kLoopX = 130.0;          // centre-line rectangle (m): perimeter ~419 m
constexpr double kLoopY = 79.7;
constexpr double kHalfWidth = 1.2;        // corridor 2.4 m wide
constexpr double kHeight = 3.0;           // floor to ceiling
constexpr double kWallThickness = 0.2;
constexpr double kCornerRadius = 1.0;     // walking line radius in the corners
constexpr double kCarryHeight = 1.4;      // handheld sensor above the floor
constexpr double kFeatureSpacingMin = 8.0, kFeatureSpacingMax = 20.0;
constexpr double kFeatureCornerMargin = 3.0;  // no features this close to a corner
constexpr double kDoorHeight = 2.1, kLintel = 0.1;
constexpr double kWalkRateMin = 1.2, kWalkRateMax = 1.4;

enum class FeatureType { kDoorFrame, kRecess, kPillar };

struct Feature {
  FeatureType type;
  double center, width, depth;
};

// A straight wall: its face lies at `face` on the across axis, the corridor is on the `into` side.
struct Wall {
  int along;    // 0: wall runs along x, 1: along y
  double face;  // across-axis coordinate of the face
  double into;  // +1 / -1: direction from the face into the corridor
  double lo, hi;
};

Eigen::Vector3d point(const Wall& w, double along, double across, double z) {
  Eigen::Vector3d p;
  p[w.along] = along;
  p[1 - w.along] = across;
  p[2] = z;
  return p;
}

void add_wall_box(World& world, const Wall& w, double a0, double a1, double c0, double c1, double z0, double z1,
                  const Material& m) {
  add_box(world, point(w, a0, c0, z0), point(w, a1, c1, z1), m);
}

void add_wall(World& world, Rng& rng, const Wall& w, std::vector<Feature> features) {
  std::sort(features.begin(), features.end(), [](const Feature& a, const Feature& b) { return a.center < b.center; });
  const Material wall = material(rng, kWall, 0.6);
  const double behind = w.face - w.into * kWallThickness;
  double cursor = w.lo;  // wall built up to here
  for (const Feature& f : features) {
    const double a0 = f.center - 0.5 * f.width, a1 = f.center + 0.5 * f.width;
    if (f.type == FeatureType::kRecess) {
      // A gap in the wall closed by a back wall `depth` behind the face and two side walls.
      add_wall_box(world, w, cursor, a0, w.face, behind, 0.0, kHeight, wall);
      const double back = w.face - w.into * f.depth;
      const Material m = material(rng, kRecess, 0.5);
      add_wall_box(world, w, a0 - kWallThickness, a1 + kWallThickness, back, back - w.into * kWallThickness, 0.0,
                   kHeight, m);
      add_wall_box(world, w, a0 - kWallThickness, a0, w.face, back, 0.0, kHeight, m);
      add_wall_box(world, w, a1, a1 + kWallThickness, w.face, back, 0.0, kHeight, m);
      cursor = a1;
    } else if (f.type == FeatureType::kDoorFrame) {
      // Two jambs and a lintel protruding `depth` into the corridor around a door `width` wide.
      const Material m = material(rng, kJamb, 0.4);
      const double out = w.face + w.into * f.depth, jamb = 0.12;
      add_wall_box(world, w, a0 - jamb, a0, w.face, out, 0.0, kDoorHeight + kLintel, m);
      add_wall_box(world, w, a1, a1 + jamb, w.face, out, 0.0, kDoorHeight + kLintel, m);
      add_wall_box(world, w, a0, a1, w.face, out, kDoorHeight, kDoorHeight + kLintel, m);
    } else {
      add_wall_box(world, w, a0, a1, w.face, w.face + w.into * f.depth, 0.0, kHeight, material(rng, kJamb, 0.45));
    }
  }
  add_wall_box(world, w, cursor, w.hi, w.face, behind, 0.0, kHeight, wall);
}

Feature draw_feature(Rng& rng, double center) {
  const int kind = rng.uniform_int(0, 2);
  Feature f{FeatureType::kPillar, center, 0.0, 0.0};
  if (kind == 0) {
    f.type = FeatureType::kDoorFrame;
    f.width = rng.uniform(0.8, 1.0);
    f.depth = rng.uniform(0.05, 0.12);
  } else if (kind == 1) {
    f.type = FeatureType::kRecess;
    f.width = rng.uniform(1.2, 2.5);
    f.depth = rng.uniform(0.4, 1.0);
  } else {
    f.width = rng.uniform(0.3, 0.5);
    f.depth = rng.uniform(0.15, 0.3);
  }
  return f;
}

}  // namespace

void build_corridor(Scenario& s, Rng& rng, Rng& motion_rng, double t0, int laps) {
  const double hw = kHalfWidth, t = kWallThickness;
  // Outer and inner walls of each side of the loop; the corridor interior is between them.
  struct Side {
    Wall outer, inner;
  };
  const Side sides[4] = {
      {{0, -hw, +1, -hw - t, kLoopX + hw + t}, {0, hw, -1, hw, kLoopX - hw}},                     // south
      {{1, kLoopX + hw, -1, -hw - t, kLoopY + hw + t}, {1, kLoopX - hw, +1, hw, kLoopY - hw}},   // east
      {{0, kLoopY + hw, -1, -hw - t, kLoopX + hw + t}, {0, kLoopY - hw, +1, hw, kLoopX - hw}},   // north
      {{1, -hw, +1, -hw - t, kLoopY + hw + t}, {1, hw, -1, hw, kLoopY - hw}},                     // west
  };
  int features = 0;
  for (const Side& side : sides) {
    std::vector<Feature> outer, inner;
    const double end = side.inner.hi - kFeatureCornerMargin;
    for (double c = side.inner.lo + kFeatureCornerMargin + rng.uniform(0.0, kFeatureSpacingMax);;
         c += rng.uniform(kFeatureSpacingMin, kFeatureSpacingMax)) {
      Feature f = draw_feature(rng, c);
      if (c + f.width > end) break;
      (rng.uniform() < 0.5 ? outer : inner).push_back(f);
      ++features;
    }
    add_wall(s.world, rng, side.outer, outer);
    add_wall(s.world, rng, side.inner, inner);
  }
  s.world.add(Plane{Eigen::Vector3d::UnitZ(), 0.0, material(rng, kFloor, 0.35)});
  s.world.add(Plane{Eigen::Vector3d::UnitZ(), kHeight, material(rng, kCeiling, 0.7)});

  const double z = kCarryHeight;
  // Round the loop `laps` times from the middle of the south side, passing straight through it
  // between laps.
  std::vector<Waypoint> waypoints = {{{0.5 * kLoopX, 0.0, z}, 0.0}};
  for (int lap = 0; lap < laps; ++lap) {
    const double through = lap + 1 < laps ? kCornerRadius : 0.0;  // collinear between laps: no corner
    waypoints.insert(waypoints.end(), {{{kLoopX, 0.0, z}, kCornerRadius},
                                       {{kLoopX, kLoopY, z}, kCornerRadius},
                                       {{0.0, kLoopY, z}, kCornerRadius},
                                       {{0.0, 0.0, z}, kCornerRadius},
                                       {{0.5 * kLoopX, 0.0, z}, through}});
  }
  const Path path = make_rounded_polyline(waypoints);
  TimeLawConfig law;
  law.rate = motion_rng.uniform(kWalkRateMin, kWalkRateMax);
  const MotionConfig motion = walking_motion(motion_rng);
  s.trajectory.emplace(path, law, motion, t0);
  s.parameters = {{"loop_x_m", kLoopX},         {"loop_y_m", kLoopY},
                  {"width_m", 2.0 * hw},        {"height_m", kHeight},
                  {"corner_radius_m", kCornerRadius}, {"carry_height_m", kCarryHeight},
                  {"features", features},       {"walk_rate_mps", law.rate}};
}

}  // namespace fuse::sim::detail

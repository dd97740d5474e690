// Scenario "campus": an open scene on a ground plane, city blocks of buildings (boxes of various
// sizes and heights) separated by 12 m streets, poles and parked cars along the kerbs, all placed
// by the world seed. A vehicle drives a ~950 m loop through the streets at 4-6 m/s.
#include "fuse/sim/motion_profiles.hpp"
#include "scenario_builders.hpp"

namespace fuse::sim::detail {

namespace {
constexpr double kBlockPitch = 70.0;             // street centre-line spacing
constexpr int kStreetsXMin = -1, kStreetsXMax = 5;  // street lines x = i * pitch
constexpr int kStreetsYMin = -1, kStreetsYMax = 4;
constexpr double kStreetHalfWidth = 6.0;
constexpr double kSetbackMin = 1.0, kSetbackMax = 4.0;  // building distance from the block edge
constexpr double kBuildingProbability = 0.8;            // per quarter block
constexpr double kHeightMin = 4.0, kHeightMax = 30.0;
constexpr double kIntersectionClear = 14.0;  // no kerb objects this close to a crossing
constexpr double kPoleOffset = 6.5, kPoleSize = 0.3, kPoleHeight = 6.0;
constexpr double kCarOffsetIn = 4.3, kCarLength = 4.5, kCarWidth = 1.8, kCarHeight = 1.5;
constexpr double kKerbSpacingMin = 12.0, kKerbSpacingMax = 30.0;
constexpr double kCornerRadius = 10.0;
constexpr double kSensorHeight = 1.9;  // roof mount
constexpr double kRateMin = 4.0, kRateMax = 6.0, kRampSeconds = 4.0;

void add_block(World& world, Rng& rng, double x0, double y0, double x1, double y1) {
  const double xm = 0.5 * (x0 + x1), ym = 0.5 * (y0 + y1);
  const double quarters[4][4] = {{x0, y0, xm, ym}, {xm, y0, x1, ym}, {x0, ym, xm, y1}, {xm, ym, x1, y1}};
  for (const auto& q : quarters) {
    if (rng.uniform() > kBuildingProbability) continue;
    const double a = rng.uniform(kSetbackMin, kSetbackMax), b = rng.uniform(kSetbackMin, kSetbackMax);
    const double c = rng.uniform(kSetbackMin, kSetbackMax), d = rng.uniform(kSetbackMin, kSetbackMax);
    const double height = rng.uniform(kHeightMin, kHeightMax);
    add_box(world, {q[0] + a, q[1] + b, 0.0}, {q[2] - c, q[3] - d, height}, material(rng, kBuilding, 0.55, 0.2));
  }
}

// Poles and parked cars along one side of a street segment between two crossings.
int add_kerb_objects(World& world, Rng& rng, int along, double line, double lo, double hi, double side) {
  int count = 0;
  for (double c = lo + kIntersectionClear + rng.uniform(0.0, kKerbSpacingMax); c < hi - kIntersectionClear;
       c += rng.uniform(kKerbSpacingMin, kKerbSpacingMax), ++count) {
    Eigen::Vector3d a, b;
    if (rng.uniform() < 0.5) {  // pole
      a[along] = c;
      b[along] = c + kPoleSize;
      a[1 - along] = line + side * kPoleOffset;
      b[1 - along] = line + side * (kPoleOffset + kPoleSize);
      a.z() = 0.0;
      b.z() = kPoleHeight;
      add_box(world, a, b, material(rng, kPole, 0.3));
    } else {  // parked car
      a[along] = c;
      b[along] = c + kCarLength;
      a[1 - along] = line + side * kCarOffsetIn;
      b[1 - along] = line + side * (kCarOffsetIn + kCarWidth);
      a.z() = 0.0;
      b.z() = kCarHeight;
      add_box(world, a, b, material(rng, kCar, 0.6, 0.3));
    }
  }
  return count;
}
}  // namespace

void build_campus(Scenario& s, Rng& rng, Rng& motion_rng, double t0) {
  const double p = kBlockPitch, hw = kStreetHalfWidth;
  int kerb_objects = 0;
  for (int i = kStreetsXMin; i < kStreetsXMax; ++i)
    for (int j = kStreetsYMin; j < kStreetsYMax; ++j)
      add_block(s.world, rng, i * p + hw, j * p + hw, (i + 1) * p - hw, (j + 1) * p - hw);
  for (int i = kStreetsXMin; i <= kStreetsXMax; ++i)  // streets along y at x = i p
    for (int j = kStreetsYMin; j < kStreetsYMax; ++j)
      for (double side : {-1.0, 1.0})
        kerb_objects += add_kerb_objects(s.world, rng, 1, i * p, j * p, (j + 1) * p, side);
  for (int j = kStreetsYMin; j <= kStreetsYMax; ++j)  // streets along x at y = j p
    for (int i = kStreetsXMin; i < kStreetsXMax; ++i)
      for (double side : {-1.0, 1.0})
        kerb_objects += add_kerb_objects(s.world, rng, 0, j * p, i * p, (i + 1) * p, side);
  s.world.add(Plane{Eigen::Vector3d::UnitZ(), 0.0, material(rng, kGround, 0.3)});

  const double z = kSensorHeight, r = kCornerRadius;
  const Path path = make_rounded_polyline({{{0.3 * p, 0.0, z}, 0.0},
                                           {{4 * p, 0.0, z}, r},
                                           {{4 * p, 2 * p, z}, r},
                                           {{2 * p, 2 * p, z}, r},
                                           {{2 * p, 3 * p, z}, r},
                                           {{0.0, 3 * p, z}, r},
                                           {{0.0, 0.0, z}, r},
                                           {{0.3 * p, 0.0, z}, 0.0}});
  TimeLawConfig law;
  law.rate = motion_rng.uniform(kRateMin, kRateMax);
  law.ramp_s = kRampSeconds;
  const MotionConfig motion = vehicle_motion(motion_rng);
  s.trajectory.emplace(path, law, motion, t0);
  s.parameters = {{"block_pitch_m", p}, {"street_width_m", 2.0 * hw}, {"buildings_and_objects", 0.0},
                  {"kerb_objects", kerb_objects}, {"drive_rate_mps", law.rate}};
  s.parameters[2].second = static_cast<double>(s.world.boxes().size());
}

}  // namespace fuse::sim::detail

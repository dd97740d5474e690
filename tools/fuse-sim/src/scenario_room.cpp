// Scenario "room": a closed 6 x 5 x 3 m room with furniture boxes along the walls (world seed),
// walked twice around a small rounded rectangle while the sensor is swung aggressively
// (angular rate peaks above 180 deg/s), about 45 s.
#include "fuse/sim/motion_profiles.hpp"
#include "scenario_builders.hpp"

namespace fuse::sim::detail {

namespace {
constexpr double kRoomX = 6.0, kRoomY = 5.0, kRoomZ = 3.0;
constexpr double kWallThickness = 0.2;
constexpr double kFurnitureBand = 1.1;  // furniture stays within this distance of the walls
constexpr int kFurnitureMin = 5, kFurnitureMax = 9;
constexpr double kLoopHalfX = 1.0, kLoopHalfY = 0.7, kLoopRadius = 0.5;  // walking loop
constexpr int kLaps = 2;
constexpr double kCarryHeight = 1.4;
constexpr double kRateMin = 0.3, kRateMax = 0.4;  // slow walk, the rotation is the point

void add_furniture(World& world, Rng& rng) {
  const double hx = 0.5 * kRoomX, hy = 0.5 * kRoomY;
  const int count = rng.uniform_int(kFurnitureMin, kFurnitureMax);
  for (int i = 0; i < count; ++i) {
    const int wall = rng.uniform_int(0, 3);  // 0: -y, 1: +x, 2: +y, 3: -x
    const double length = rng.uniform(0.4, 1.6), depth = rng.uniform(0.3, kFurnitureBand);
    const double height = rng.uniform(0.4, 2.2);
    const bool along_x = wall % 2 == 0;
    const double span = (along_x ? hx : hy) - 0.5 * length;
    const double c = rng.uniform(-span, span);
    const double sign = (wall == 0 || wall == 3) ? -1.0 : 1.0;
    const double w = along_x ? hy : hx;
    const double gap = rng.uniform(0.0, 0.1);  // some pieces stand off the wall
    Eigen::Vector3d a, b;
    if (along_x) {
      a = {c - 0.5 * length, sign * (w - gap), 0.0};
      b = {c + 0.5 * length, sign * (w - gap - depth), height};
    } else {
      a = {sign * (w - gap), c - 0.5 * length, 0.0};
      b = {sign * (w - gap - depth), c + 0.5 * length, height};
    }
    add_box(world, a, b, material(rng, kFurniture, 0.5, 0.3));
  }
}
}  // namespace

void build_room(Scenario& s, Rng& rng, Rng& motion_rng, double t0) {
  const double hx = 0.5 * kRoomX, hy = 0.5 * kRoomY, t = kWallThickness;
  const Material wall = material(rng, kWall, 0.6);
  add_box(s.world, {-hx - t, -hy - t, -t}, {hx + t, hy + t, 0.0}, material(rng, kFloor, 0.35));
  add_box(s.world, {-hx - t, -hy - t, kRoomZ}, {hx + t, hy + t, kRoomZ + t}, material(rng, kCeiling, 0.7));
  add_box(s.world, {-hx - t, -hy - t, 0.0}, {hx + t, -hy, kRoomZ}, wall);
  add_box(s.world, {-hx - t, hy, 0.0}, {hx + t, hy + t, kRoomZ}, wall);
  add_box(s.world, {-hx - t, -hy, 0.0}, {-hx, hy, kRoomZ}, wall);
  add_box(s.world, {hx, -hy, 0.0}, {hx + t, hy, kRoomZ}, wall);
  add_furniture(s.world, rng);

  const double z = kCarryHeight, ax = kLoopHalfX, ay = kLoopHalfY, r = kLoopRadius;
  std::vector<Waypoint> waypoints = {{{0.0, -ay, z}, 0.0}};
  for (int lap = 0; lap < kLaps; ++lap)
    for (const auto& corner : {Eigen::Vector3d(ax, -ay, z), Eigen::Vector3d(ax, ay, z), Eigen::Vector3d(-ax, ay, z),
                               Eigen::Vector3d(-ax, -ay, z)})
      waypoints.push_back({corner, r});
  waypoints.push_back({{0.0, -ay, z}, 0.0});
  TimeLawConfig law;
  law.rate = motion_rng.uniform(kRateMin, kRateMax);
  const MotionConfig motion = aggressive_handheld_motion(motion_rng);
  s.trajectory.emplace(make_rounded_polyline(waypoints), law, motion, t0);
  s.parameters = {{"room_x_m", kRoomX}, {"room_y_m", kRoomY}, {"room_z_m", kRoomZ}, {"laps", kLaps},
                  {"walk_rate_mps", law.rate}};
}

}  // namespace fuse::sim::detail

#include "fuse/sim/scenario.hpp"

#include <algorithm>
#include <stdexcept>

#include "fuse/sim/imu_model.hpp"  // kDegToRad
#include "scenario_builders.hpp"

namespace fuse::sim {

Eigen::Isometry3d default_T_imu_lidar() {
  const Eigen::Vector3d rpy = kLidarInImuRpyDeg * kDegToRad;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  T.translation() = kLidarInImuTranslation;
  return T;
}

const std::vector<std::string>& scenario_names() {
  static const std::vector<std::string> names = {"corridor", "stairs", "room", "campus", "urban"};
  return names;
}

bool scenario_has_traffic(const std::string& name) { return name == "urban"; }
bool scenario_can_stop(const std::string& name) { return name == "urban"; }

namespace {
/// The trajectory again with `stops` stops: at the stop line before each of the first corners'
/// slow stretches (the law's speed limits in path order), for kStopDwellS each.
void add_stops(Scenario& s, int stops) {
  const Trajectory& full = *s.trajectory;
  TimeLawConfig law = full.time_law().config();
  std::vector<SpeedLimit> limits = law.limits;
  std::sort(limits.begin(), limits.end(), [](const SpeedLimit& a, const SpeedLimit& b) { return a.u_begin < b.u_begin; });
  if (stops < 0 || static_cast<std::size_t>(stops) > limits.size())
    throw std::invalid_argument("stops: the '" + s.name + "' drive has " + std::to_string(limits.size()) +
                                " corners to stop before");
  for (int k = 0; k < stops; ++k) {
    law.stops.push_back({limits[static_cast<std::size_t>(k)].u_begin - kStopLineM, kStopDwellS});
    s.parameters.emplace_back("stop_" + std::to_string(k) + "_u_m", law.stops.back().u);
  }
  s.parameters.emplace_back("stops", stops);
  s.parameters.emplace_back("stop_dwell_s", kStopDwellS);
  const Path path = full.path();  // copies: emplace destroys `full`
  const MotionConfig motion = full.motion();
  const double t0 = full.t_begin();
  s.trajectory.emplace(path, law, motion, t0);
}
}  // namespace

Scenario make_scenario(const std::string& name, std::uint64_t world_seed, std::uint64_t seed, double t0, int laps,
                       double start_at, bool traffic, int stops) {
  Scenario s;
  s.name = name;
  Rng world_rng(world_seed, Stream::kWorld);
  Rng motion_rng(seed, Stream::kMotion);
  if (laps < 1) throw std::invalid_argument("laps must be at least 1");
  if (laps > 1 && name != "corridor") {
    throw std::invalid_argument("laps: only the corridor's path is a loop ('" + name + "' is walked once)");
  }
  if (name == "corridor")
    detail::build_corridor(s, world_rng, motion_rng, t0, laps);
  else if (name == "stairs")
    detail::build_stairs(s, world_rng, motion_rng, t0);
  else if (name == "room")
    detail::build_room(s, world_rng, motion_rng, t0);
  else if (name == "campus")
    detail::build_campus(s, world_rng, motion_rng, t0);
  else if (name == "urban")
    detail::build_urban(s, world_rng, motion_rng, t0);
  else
    throw std::invalid_argument("unknown scenario '" + name + "' (expected corridor, stairs, room, campus or urban)");
  if (stops != 0) {
    if (!scenario_can_stop(name)) throw std::invalid_argument("stops: only the urban drive stops ('" + name + "' does not)");
    add_stops(s, stops);
  }
  if (start_at != 0.0) {
    // The same world and path; the walk starts start_at along it, at rest, with this seed's motion.
    const Trajectory& full = *s.trajectory;
    if (!(start_at > 0.0) || !(start_at < full.path().u_end())) {
      throw std::invalid_argument("start_at: must lie on the path (0 to " + std::to_string(full.path().u_end()) + " m)");
    }
    const Path rest = full.path().from(start_at);
    const TimeLawConfig law = full.time_law().config().from(start_at);
    const MotionConfig motion = full.motion();
    s.trajectory.emplace(rest, law, motion, t0);
    s.parameters.emplace_back("start_at_m", start_at);
  }
  s.world.build();
  if (traffic && s.streets) {
    // Its own stream of the world seed: the static world is the same with or without traffic.
    Rng traffic_rng(world_seed, Stream::kTraffic);
    s.traffic = populate_streets(*s.streets, TrafficConfig{}, *s.trajectory, traffic_rng, s.traffic_stats);
  }
  return s;
}

namespace detail {

Material material(Rng& rng, SurfaceId id, double base, double jitter) {
  Material m;
  m.surface_id = id;
  m.reflectivity = base + rng.uniform(-jitter, jitter);
  return m;
}

void add_box(World& world, const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Material& m) {
  Box box;
  box.min = a.cwiseMin(b);
  box.max = a.cwiseMax(b);
  box.material = m;
  world.add(box);
}

}  // namespace detail
}  // namespace fuse::sim

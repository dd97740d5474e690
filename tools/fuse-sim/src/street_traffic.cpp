#include "fuse/sim/street_traffic.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "scenario_builders.hpp"  // surface ids

namespace fuse::sim {

namespace {
constexpr int kStartTries = 6;  // new starts along the loop before a draw is replaced
constexpr int kDrawTries = 8;   // draws before a mover is given up
constexpr double kCarReflectivityMin = 0.3, kCarReflectivityMax = 0.9;
constexpr double kPedestrianReflectivityMin = 0.2, kPedestrianReflectivityMax = 0.6;

constexpr int kRouteDraws = 200;       // draws before a mover is accepted off the platform's route anyway
constexpr double kRouteSampleM = 5.0;  // spacing of the path points the loops are measured against

Eigen::Vector2d right_of(const Eigen::Vector2d& d) { return {d.y(), -d.x()}; }

// Distance from p to the closed loop's segments.
double distance_to_loop(const std::vector<Eigen::Vector2d>& loop, const Eigen::Vector2d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < loop.size(); ++k) {
    const Eigen::Vector2d a = loop[k], d = loop[(k + 1) % loop.size()] - a;
    const double s = std::clamp((p - a).dot(d) / d.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (a + s * d - p).norm());
  }
  return best;
}

Mover draw_car(const StreetGrid& g, const TrafficConfig& c, Rng& rng) {
  const int nx = static_cast<int>(g.x_lines.size()), ny = static_cast<int>(g.y_lines.size());
  const int i0 = rng.uniform_int(0, nx - 2);
  const int i1 = i0 + rng.uniform_int(1, std::min(c.max_loop_blocks, nx - 1 - i0));
  const int j0 = rng.uniform_int(0, ny - 2);
  const int j1 = j0 + rng.uniform_int(1, std::min(c.max_loop_blocks, ny - 1 - j0));
  std::vector<Eigen::Vector2d> corners = {{g.x_lines[i0], g.y_lines[j0]},
                                          {g.x_lines[i1], g.y_lines[j0]},
                                          {g.x_lines[i1], g.y_lines[j1]},
                                          {g.x_lines[i0], g.y_lines[j1]}};  // counter-clockwise
  if (rng.uniform() < 0.5) std::reverse(corners.begin(), corners.end());
  const double lane = rng.uniform() < 0.5 ? g.inner_lane : g.outer_lane;
  Mover m;
  m.kind = MoverKind::kCar;
  m.loop = offset_loop(corners, lane);  // right-hand traffic: the lane right of the centre line
  m.length = c.car_length;
  m.width = c.car_width;
  m.height = c.car_height;
  m.speed = rng.uniform(c.car_speed_min, c.car_speed_max);
  m.material.surface_id = detail::kMovingCar;
  m.material.reflectivity = rng.uniform(kCarReflectivityMin, kCarReflectivityMax);
  return m;
}

Mover draw_pedestrian(const StreetGrid& g, const TrafficConfig& c, Rng& rng) {
  const int nx = static_cast<int>(g.x_lines.size()), ny = static_cast<int>(g.y_lines.size());
  const double w = rng.uniform(g.walk_min, g.walk_max), s = g.crosswalk_setback;
  std::vector<Eigen::Vector2d> corners;
  if (rng.uniform() >= c.crossing_share) {  // round a block on its sidewalks
    const int i = rng.uniform_int(0, nx - 2), j = rng.uniform_int(0, ny - 2);
    const double x0 = g.x_lines[i] + w, x1 = g.x_lines[i + 1] - w, y0 = g.y_lines[j] + w, y1 = g.y_lines[j + 1] - w;
    corners = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  } else if (rng.uniform() < 0.5) {  // across a street along x, at the crosswalks near both ends
    const int i = rng.uniform_int(0, nx - 2), j = rng.uniform_int(0, ny - 1);
    const double x0 = g.x_lines[i] + s, x1 = g.x_lines[i + 1] - s, y = g.y_lines[j];
    corners = {{x0, y - w}, {x1, y - w}, {x1, y + w}, {x0, y + w}};
  } else {  // across a street along y
    const int i = rng.uniform_int(0, nx - 1), j = rng.uniform_int(0, ny - 2);
    const double y0 = g.y_lines[j] + s, y1 = g.y_lines[j + 1] - s, x = g.x_lines[i];
    corners = {{x - w, y0}, {x + w, y0}, {x + w, y1}, {x - w, y1}};
  }
  if (rng.uniform() < 0.5) std::reverse(corners.begin(), corners.end());
  Mover m;
  m.kind = MoverKind::kPedestrian;
  m.loop = corners;
  m.length = m.width = c.pedestrian_size;
  m.height = c.pedestrian_height;
  m.speed = rng.uniform(c.pedestrian_speed_min, c.pedestrian_speed_max);
  m.material.surface_id = detail::kPedestrian;
  m.material.reflectivity = rng.uniform(kPedestrianReflectivityMin, kPedestrianReflectivityMax);
  return m;
}

}  // namespace

std::vector<Eigen::Vector2d> offset_loop(const std::vector<Eigen::Vector2d>& loop, double right) {
  const std::size_t n = loop.size();
  std::vector<Eigen::Vector2d> out;
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector2d in = (loop[k] - loop[(k + n - 1) % n]).normalized();
    const Eigen::Vector2d on = (loop[(k + 1) % n] - loop[k]).normalized();
    const double turn = in.dot(on);
    if (std::abs(turn) > 1e-9 && turn < 1.0 - 1e-9)
      throw std::invalid_argument("offset_loop: corners must be right angles (or straight through)");
    // Perpendicular: the offset lines meet at v + right (r_in + r_out); straight through: v + right r.
    out.push_back(loop[k] + right * (turn > 0.5 ? right_of(in) : Eigen::Vector2d(right_of(in) + right_of(on))));
  }
  return out;
}

bool near_ego(const Traffic& traffic, std::size_t i, const TrajectoryState& ego, double t, const TrafficConfig& c,
              double clearance) {
  const Box b = traffic.box(i, t);
  const Eigen::Vector2d m = 0.5 * (b.min + b.max).head<2>(), e = 0.5 * (b.max - b.min).head<2>();
  const double hl = 0.5 * c.ego_length + clearance, hw = 0.5 * c.ego_width + clearance;
  const Eigen::Vector2d d = ego.p.head<2>() - m;
  if (d.norm() > std::hypot(hl, hw) + e.norm()) return false;  // far apart: no need for the axes
  const Eigen::Vector2d u = ego.R.col(0).head<2>().normalized(), v(-u.y(), u.x());
  // Separating axes: the box's x and y, the ego's forward u and left v.
  if (std::abs(d.x()) > e.x() + hl * std::abs(u.x()) + hw * std::abs(v.x())) return false;
  if (std::abs(d.y()) > e.y() + hl * std::abs(u.y()) + hw * std::abs(v.y())) return false;
  if (std::abs(d.dot(u)) > hl + e.x() * std::abs(u.x()) + e.y() * std::abs(u.y())) return false;
  if (std::abs(d.dot(v)) > hw + e.x() * std::abs(v.x()) + e.y() * std::abs(v.y())) return false;
  return true;
}

Traffic populate_streets(const StreetGrid& g, const TrafficConfig& c, const Trajectory& ego, Rng& rng,
                         TrafficStats& stats) {
  if (g.x_lines.size() < 2 || g.y_lines.size() < 2 || !std::is_sorted(g.x_lines.begin(), g.x_lines.end()) ||
      !std::is_sorted(g.y_lines.begin(), g.y_lines.end()))
    throw std::invalid_argument("street traffic: need at least two ascending street lines each way");
  if (c.cars < 0 || c.pedestrians < 0 || !(c.check_period_s > 0.0) || c.max_loop_blocks < 1)
    throw std::invalid_argument("street traffic: bad counts or check period");
  stats = {};
  std::vector<TrajectoryState> path;  // the platform along its whole trajectory
  for (double t = ego.t_begin(); t <= ego.t_end(); t += c.check_period_s) path.push_back(ego.state(t));
  path.push_back(ego.state(ego.t_end()));

  std::vector<Eigen::Vector2d> route;  // the platform's path every few metres
  for (const TrajectoryState& s : path)
    if (route.empty() || (s.p.head<2>() - route.back()).norm() >= kRouteSampleM) route.push_back(s.p.head<2>());
  const auto near_route = [&](const Mover& m) {
    return c.route_reach <= 0.0 || std::any_of(route.begin(), route.end(), [&](const Eigen::Vector2d& p) {
             return distance_to_loop(m.loop, p) <= c.route_reach;
           });
  };

  std::vector<Mover> movers;
  const int total = c.cars + c.pedestrians;
  for (int n = 0; n < total; ++n) {
    const bool car = n < c.cars;
    bool placed = false;
    for (int draw = 0; draw < kDrawTries && !placed; ++draw) {
      Mover m = car ? draw_car(g, c, rng) : draw_pedestrian(g, c, rng);
      for (int again = 0; again < kRouteDraws && !near_route(m); ++again, ++stats.off_route)
        m = car ? draw_car(g, c, rng) : draw_pedestrian(g, c, rng);
      m.id = static_cast<std::uint32_t>(movers.size());
      Traffic one({m}, ego.t_begin());
      for (int start = 0; start < kStartTries && !placed; ++start) {
        m.offset = rng.uniform(0.0, one.loop_length(0));
        one = Traffic({m}, ego.t_begin());
        placed = std::none_of(path.begin(), path.end(),
                              [&](const TrajectoryState& s) { return near_ego(one, 0, s, s.t, c, c.clearance); });
        if (!placed) ++stats.redraws;
      }
      if (placed) movers.push_back(m);
    }
    if (!placed)
      ++stats.dropped;
    else
      ++(car ? stats.cars : stats.pedestrians);
  }
  return Traffic(std::move(movers), ego.t_begin());
}

}  // namespace fuse::sim

// Moving objects of the urban scenario: they move, keep clear of the ego vehicle and of the static
// world, the LiDAR labels exactly the points that hit them, a run without them has the same static
// points, and the swept volume (for the map classifier) covers every position.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>

#include "fuse/sim/lidar_model.hpp"
#include "fuse/sim/scenario.hpp"
#include "fuse/sim/street_traffic.hpp"
#include "fuse/sim/traffic.hpp"

using namespace fuse::sim;

namespace {
bool overlaps(const Box& a, const Box& b) {
  return (a.min.array() < b.max.array()).all() && (b.min.array() < a.max.array()).all();
}
Eigen::Vector3d centre(const Box& b) { return 0.5 * (b.min + b.max); }
}  // namespace

TEST(SimTraffic, MoversMoveInTheirLanesAtTheirSpeeds) {
  const Scenario s = make_scenario("urban", 1, 1);
  ASSERT_TRUE(s.traffic);
  const Traffic& tr = *s.traffic;
  const TrafficConfig cfg;
  EXPECT_EQ(s.traffic_stats.cars, cfg.cars);
  EXPECT_EQ(s.traffic_stats.pedestrians, cfg.pedestrians);
  EXPECT_EQ(s.traffic_stats.dropped, 0);
  ASSERT_EQ(tr.movers().size(), static_cast<std::size_t>(cfg.cars + cfg.pedestrians));
  const double t = s.trajectory->t_begin() + 20.0;
  for (std::size_t i = 0; i < tr.movers().size(); ++i) {
    const Mover& m = tr.movers()[i];
    EXPECT_EQ(m.id, i);
    if (m.kind == MoverKind::kCar) {
      EXPECT_GE(m.speed, 5.0);
      EXPECT_LE(m.speed, 15.0);
      EXPECT_NEAR(m.length, 4.5, 1e-12);
    } else {
      EXPECT_GE(m.speed, 1.0);
      EXPECT_LE(m.speed, 2.0);
      EXPECT_NEAR(m.height, 1.7, 1e-12);
    }
    // 0.1 s later the box has moved by speed * 0.1 (straight on) or less (round a corner).
    const Box a = tr.box(i, t), b = tr.box(i, t + 0.1);
    const double moved = (centre(b) - centre(a)).norm();
    EXPECT_LE(moved, m.speed * 0.1 + 1e-9);
    EXPECT_GT(moved, 0.5 * m.speed * 0.1);
    EXPECT_EQ(a.min.z(), 0.0);
    // Cars drive in a lane, pedestrians walk on a sidewalk or a crosswalk: a fixed distance from a
    // street's centre line (x = 130 i or y = 110 j), across their direction of travel.
    Eigen::Vector2d c, d;
    tr.pose(i, t, c, d);
    const double across = std::abs(d.x()) > 0.5 ? c.y() : c.x(), pitch = std::abs(d.x()) > 0.5 ? 110.0 : 130.0;
    const double offset = std::abs(across - pitch * std::round(across / pitch));
    if (m.kind == MoverKind::kCar)
      EXPECT_TRUE(std::abs(offset - 1.75) < 1e-9 || std::abs(offset - 5.25) < 1e-9) << "car " << i << " " << offset;
    else  // along a sidewalk, or on a crosswalk 15 m from the crossing street's centre line
      EXPECT_TRUE((offset >= 11.4 && offset <= 12.2) || std::abs(offset - 15.0) < 1e-9)
          << "pedestrian " << i << " " << offset;
  }
}

// Every mover at every 5 ms of the drive: never overlapping the ego vehicle's footprint, and at
// every 0.5 s never inside a static box (buildings, parked cars, poles, trees).
TEST(SimTraffic, MoversNeverMeetTheEgoVehicleOrTheStaticWorld) {
  const Scenario s = make_scenario("urban", 2, 2);
  const Traffic& tr = *s.traffic;
  const Trajectory& ego = *s.trajectory;
  const TrafficConfig cfg;
  std::size_t close_calls = 0;  // within 3 m: the check has something to check
  for (double t = ego.t_begin(); t <= ego.t_end(); t += 0.005) {
    const TrajectoryState x = ego.state(t);
    for (std::size_t i = 0; i < tr.movers().size(); ++i) {
      ASSERT_FALSE(near_ego(tr, i, x, t, cfg, 0.0)) << "mover " << i << " meets the ego vehicle at t=" << t;
      close_calls += near_ego(tr, i, x, t, cfg, 3.0);
    }
  }
  EXPECT_GT(close_calls, 100u) << "oncoming and crossing traffic passes close by";
  for (double t = ego.t_begin(); t <= ego.t_end(); t += 0.5)
    for (std::size_t i = 0; i < tr.movers().size(); ++i) {
      const Box b = tr.box(i, t);
      for (const Box& w : s.world.boxes())
        ASSERT_FALSE(overlaps(b, w)) << "mover " << i << " in a static box at t=" << t;
    }
}

TEST(SimTraffic, SweptVolumeCoversEveryPositionAndNoMore) {
  const Scenario s = make_scenario("urban", 3, 3);
  const Traffic& tr = *s.traffic;
  const double t0 = s.trajectory->t_begin(), t1 = t0 + 30.0;
  const std::vector<Box> swept = tr.swept_volume(t0, t1);
  World world;
  for (const Box& b : swept) world.add(b);
  world.build();
  for (double t = t0; t <= t1; t += 0.25)
    for (std::size_t i = 0; i < tr.movers().size(); ++i) {
      const Box b = tr.box(i, t);
      for (const Eigen::Vector3d& corner : {b.min, b.max, Eigen::Vector3d(b.min.x(), b.max.y(), 1.0)})
        ASSERT_LT(world.clearance(corner), 1e-9) << "mover " << i << " t=" << t - t0;
    }
  // The swept area is about the path travelled times the width (plus a length at each corner).
  double area = 0.0, expected = 0.0;
  for (const Box& b : swept) area += (b.max - b.min).head<2>().prod();
  for (const Mover& m : tr.movers()) expected += (m.speed * 30.0 + 6.0 * m.length) * m.width;
  EXPECT_LT(area, expected);
  // Over a whole lap or more, the swept volume is the whole loop.
  const std::vector<Box> all = tr.swept_volume(t0, t0 + 1e4);
  double loop_area = 0.0, loops = 0.0;
  for (const Box& b : all) loop_area += (b.max - b.min).head<2>().prod();
  for (std::size_t i = 0; i < tr.movers().size(); ++i) loops += tr.loop_length(i) * tr.movers()[i].width;
  EXPECT_GT(loop_area, loops);
}

// Noise-free LiDAR: a point is labelled moving exactly when its shot, cast again against the movers
// alone, hits one at the point's range while the static world alone puts it no nearer (or nowhere);
// a static point lies on a static surface with no mover in front of it.
TEST(SimTraffic, LabelsAreOneExactlyForShotsThatHitAMover) {
  const Scenario s = make_scenario("urban", 1, 1);
  const Trajectory& tr = *s.trajectory;
  LidarConfig c = LidarConfig::mid360();
  c.range_noise_sigma_m = 0.0;
  c.angular_noise_sigma_rad = 0.0;
  const Eigen::Isometry3d T_il = default_T_imu_lidar();
  LidarSimulator sim(c, s.world, tr, T_il, 1, &*s.traffic);
  std::size_t moving = 0, still = 0, in_front = 0;
  for (std::uint64_t k : {10u, 300u, 600u, 900u, 1200u}) {
    std::vector<std::uint8_t> labels;
    const fuse::LidarScan scan = sim.scan(k, tr.t_begin(), &labels);
    ASSERT_EQ(labels.size(), scan.points.size());
    for (std::size_t i = 0; i < scan.points.size(); ++i) {
      const fuse::LidarPoint& p = scan.points[i];
      const Eigen::Vector3d pl(p.x, p.y, p.z);
      const TrajectoryState x = tr.state(scan.t_start + p.t_rel);
      const Eigen::Vector3d origin = x.p + x.R * T_il.translation();
      const Eigen::Vector3d dir = x.R * T_il.linear() * pl.normalized();
      const double r = pl.norm();
      const Hit statics = s.world.cast(origin, dir, c.max_range_m);
      double movers = std::numeric_limits<double>::infinity();
      for (std::size_t m = 0; m < s.traffic->movers().size(); ++m)
        movers = std::min(movers, intersect(s.traffic->box(m, scan.t_start + p.t_rel), origin, dir).range);
      if (labels[i] == 0) {
        ASSERT_LT(s.world.clearance(origin + r * dir), 1e-4) << "scan " << k << " point " << i;
        ASSERT_GE(movers, r - 1e-4) << "scan " << k << " point " << i;
        ++still;
      } else {
        ASSERT_EQ(labels[i], 1);
        ASSERT_NEAR(movers, r, 1e-4) << "scan " << k << " point " << i;
        ASSERT_TRUE(!statics.valid() || statics.range >= r - 1e-4) << "scan " << k << " point " << i;
        in_front += !statics.valid() || statics.range > r + 0.05;
        ++moving;
      }
    }
  }
  EXPECT_GT(moving, 200u);
  EXPECT_GT(in_front, moving / 2);
  EXPECT_GT(still, 40000u);
}

// --traffic off: the same static world, path and noise; every static point of the run with
// traffic is in the run without it, bit for bit, and the static run's other points are exactly
// those the movers hid.
TEST(SimTraffic, WithoutTrafficTheStaticPointsAreTheSame) {
  const Scenario with = make_scenario("urban", 5, 6), without = make_scenario("urban", 5, 6, kStartTime, 1, 0.0, false);
  EXPECT_FALSE(without.traffic);
  ASSERT_EQ(with.world.boxes().size(), without.world.boxes().size());
  for (std::size_t i = 0; i < with.world.boxes().size(); ++i) {
    ASSERT_EQ(with.world.boxes()[i].min, without.world.boxes()[i].min);
    ASSERT_EQ(with.world.boxes()[i].max, without.world.boxes()[i].max);
  }
  const Trajectory& tr = *with.trajectory;
  for (double t = tr.t_begin(); t < tr.t_end(); t += 3.7)
    ASSERT_EQ((tr.state(t).p - without.trajectory->state(t).p).norm(), 0.0);
  LidarSimulator a(LidarConfig::mid360(), with.world, tr, default_T_imu_lidar(), 6, &*with.traffic);
  LidarSimulator b(LidarConfig::mid360(), without.world, *without.trajectory, default_T_imu_lidar(), 6);
  std::size_t hidden = 0, moving = 0;
  for (std::uint64_t k = 0; k < 30; ++k) {
    std::vector<std::uint8_t> la, lb;
    const fuse::LidarScan sa = a.scan(k, tr.t_begin(), &la), sb = b.scan(k, tr.t_begin(), &lb);
    for (std::uint8_t l : lb) ASSERT_EQ(l, 0);
    // Points keyed by their shot (time and line).
    std::map<std::pair<float, std::uint16_t>, const fuse::LidarPoint*> statics;
    for (const fuse::LidarPoint& p : sb.points) statics[{p.t_rel, p.ring}] = &p;
    std::size_t matched = 0;
    for (std::size_t i = 0; i < sa.points.size(); ++i) {
      const fuse::LidarPoint& p = sa.points[i];
      const auto it = statics.find({p.t_rel, p.ring});
      if (la[i] == 1) {
        ++moving;
        continue;
      }
      ASSERT_NE(it, statics.end()) << "scan " << k;
      const fuse::LidarPoint& q = *it->second;
      ASSERT_TRUE(p.x == q.x && p.y == q.y && p.z == q.z && p.intensity == q.intensity) << "scan " << k;
      ++matched;
    }
    ASSERT_LE(sb.points.size() - matched, static_cast<std::size_t>(std::count(la.begin(), la.end(), std::uint8_t{1})));
    hidden += sb.points.size() - matched;
  }
  EXPECT_GT(moving, 100u);
  EXPECT_GT(hidden, 50u);
}

TEST(SimTraffic, LoopsAndOffsetsAreChecked) {
  Mover m;
  m.loop = {{0, 0}, {10, 0}, {10, 5}, {0, 5}};
  EXPECT_NO_THROW(Traffic({m}, 0.0));
  Mover diagonal = m;
  diagonal.loop = {{0, 0}, {10, 3}, {0, 5}};
  EXPECT_THROW(Traffic({diagonal}, 0.0), std::invalid_argument);
  Mover still = m;
  still.speed = 0.0;
  EXPECT_THROW(Traffic({still}, 0.0), std::invalid_argument);
  // Counter-clockwise round a square moved to the right of travel: outwards.
  const std::vector<Eigen::Vector2d> lane = offset_loop({{0, 0}, {10, 0}, {10, 10}, {0, 10}}, 1.0);
  EXPECT_EQ(lane[0], Eigen::Vector2d(-1, -1));
  EXPECT_EQ(lane[2], Eigen::Vector2d(11, 11));
  // A box going round: length along x on the first side, along y on the second.
  m.length = 4.0;
  m.width = 2.0;
  m.speed = 1.0;
  const Traffic t({m}, 0.0);
  EXPECT_NEAR(t.loop_length(0), 30.0, 1e-12);
  Box b = t.box(0, 5.0);
  EXPECT_EQ(b.min, Eigen::Vector3d(3, -1, 0));
  EXPECT_EQ(b.max, Eigen::Vector3d(7, 1, m.height));
  b = t.box(0, 12.0);
  EXPECT_EQ(b.min, Eigen::Vector3d(9, 0, 0));
  EXPECT_EQ(b.max, Eigen::Vector3d(11, 4, m.height));
  EXPECT_EQ(t.box(0, 35.0).min, t.box(0, 5.0).min);  // one lap later
}

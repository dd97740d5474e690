// LiDAR pattern statistics and the measurement model: every point, put back into the world with
// the true pose at its own time, lies on a surface (noise-free), and not with the frame-start pose.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "fuse/sim/lidar_model.hpp"
#include "fuse/sim/scenario.hpp"

using namespace fuse::sim;

namespace {
double elevation_deg(const Eigen::Vector3d& d) { return std::atan2(d.z(), d.head<2>().norm()) * 180 / M_PI; }
}  // namespace

TEST(SimLidarPattern, Mid360Statistics) {
  const LidarConfig c = LidarConfig::mid360();
  std::vector<Shot> shots, next;
  generate_shots(c, 0, shots);
  generate_shots(c, 1, next);
  ASSERT_EQ(shots.size(), 20000u);
  int per_ring[4] = {0, 0, 0, 0};
  double el_min = 90, el_max = -90;
  int az_bins[36] = {};
  for (std::size_t i = 0; i < shots.size(); ++i) {
    const Shot& s = shots[i];
    ASSERT_LT(s.ring, 4);
    ++per_ring[s.ring];
    ASSERT_GE(s.t_rel, 0.f);
    ASSERT_LT(s.t_rel, 0.1f);
    if (i > 0) {
      ASSERT_GT(s.t_rel, shots[i - 1].t_rel);
    }
    ASSERT_NEAR(s.dir.norm(), 1.0, 1e-12);
    el_min = std::min(el_min, elevation_deg(s.dir));
    el_max = std::max(el_max, elevation_deg(s.dir));
    ++az_bins[static_cast<int>((std::atan2(s.dir.y(), s.dir.x()) + M_PI) / (2 * M_PI) * 36) % 36];
  }
  for (int r = 0; r < 4; ++r) EXPECT_EQ(per_ring[r], 5000);
  EXPECT_NEAR(el_min, -7.0, 0.05);
  EXPECT_NEAR(el_max, 52.0, 0.05);
  for (int b : az_bins) EXPECT_GT(b, 400);  // 360 deg azimuth coverage
  // Non-repetitive: the next frame fires in other directions.
  int same = 0;
  for (std::size_t i = 0; i < shots.size(); ++i) same += (shots[i].dir - next[i].dir).norm() < 1e-3;
  EXPECT_LT(same, 200);
}

TEST(SimLidarPattern, Spinning32Statistics) {
  const LidarConfig c = LidarConfig::spinning32();
  std::vector<Shot> shots;
  generate_shots(c, 3, shots);
  ASSERT_EQ(shots.size(), 32u * 1800u);
  std::set<int> rings;
  double el_min = 90, el_max = -90;
  for (const Shot& s : shots) {
    rings.insert(s.ring);
    el_min = std::min(el_min, elevation_deg(s.dir));
    el_max = std::max(el_max, elevation_deg(s.dir));
    ASSERT_LT(s.t_rel, 0.1f);
  }
  EXPECT_EQ(rings.size(), 32u);
  EXPECT_NEAR(el_min, -16.0, 1e-9);
  EXPECT_NEAR(el_max, 15.0, 1e-9);
  EXPECT_EQ(shots[0].t_rel, shots[31].t_rel);  // one column fires together
  EXPECT_GT(shots[32].t_rel, shots[31].t_rel);
  EXPECT_THROW(LidarConfig::from_name("velodyne"), std::invalid_argument);
}

TEST(SimLidarPattern, Spinning64Statistics) {
  const LidarConfig c = LidarConfig::from_name("spinning64");
  EXPECT_EQ(c.type, LidarType::kSpinning64);
  EXPECT_EQ(c.shots_per_frame(), 64 * 1024);
  std::vector<Shot> shots;
  generate_shots(c, 5, shots);
  ASSERT_EQ(shots.size(), 64u * 1024u);
  std::set<int> rings;
  std::set<float> times;
  double el_min = 90, el_max = -90;
  for (const Shot& s : shots) {
    rings.insert(s.ring);
    times.insert(s.t_rel);
    el_min = std::min(el_min, elevation_deg(s.dir));
    el_max = std::max(el_max, elevation_deg(s.dir));
    ASSERT_LT(s.t_rel, 0.1f);
  }
  EXPECT_EQ(rings.size(), 64u);
  EXPECT_EQ(times.size(), 1024u);  // one firing time per column
  EXPECT_NEAR(el_min, -22.5, 1e-9);
  EXPECT_NEAR(el_max, 22.5, 1e-9);
  EXPECT_NEAR(elevation_deg(shots[1].dir) - elevation_deg(shots[0].dir), 45.0 / 63.0, 1e-9);
  EXPECT_EQ(shots[0].t_rel, shots[63].t_rel);
  EXPECT_GT(shots[64].t_rel, shots[63].t_rel);
  // Every scenario casts it: the urban scan has all 64 rings and long returns.
  const Scenario s = make_scenario("urban", 1, 1);
  LidarSimulator sim(c, s.world, *s.trajectory, default_T_imu_lidar(), 1, &*s.traffic);
  std::vector<std::uint8_t> labels;
  const fuse::LidarScan scan = sim.scan(300, s.trajectory->t_begin(), &labels);
  EXPECT_GT(scan.points.size(), 30000u);
  EXPECT_LE(scan.points.size(), 65536u);
  std::set<int> seen;
  for (const fuse::LidarPoint& p : scan.points) seen.insert(p.ring);
  EXPECT_EQ(seen.size(), 64u);
  EXPECT_EQ(labels.size(), scan.points.size());
}

TEST(SimLidar, CorridorScanStatistics) {
  const Scenario s = make_scenario("corridor", 1, 1);
  const Trajectory& tr = *s.trajectory;
  LidarSimulator sim(LidarConfig::mid360(), s.world, tr, default_T_imu_lidar(), 1);
  for (std::uint64_t k : {0u, 70u, 150u}) {
    const fuse::LidarScan scan = sim.scan(k, tr.t_begin());
    EXPECT_GT(scan.points.size(), 19500u);
    EXPECT_LE(scan.points.size(), 20000u);
    EXPECT_DOUBLE_EQ(scan.t_start, tr.t_begin() + 0.1 * k);
    EXPECT_NEAR(scan.t_end - scan.t_start, 0.1, 1e-9);
    std::set<int> rings;
    for (const fuse::LidarPoint& p : scan.points) {
      const double r = std::sqrt(double(p.x) * p.x + double(p.y) * p.y + double(p.z) * p.z);
      ASSERT_GE(r, 0.1);
      ASSERT_LE(r, 40.0);
      ASSERT_GE(p.intensity, 0.f);
      ASSERT_LE(p.intensity, 255.f);
      rings.insert(p.ring);
    }
    EXPECT_EQ(rings.size(), 4u);
  }
}

namespace {
// A hollow cube of half-size h around the origin (six wall boxes 0.1 m thick).
World hollow_cube(double h) {
  World w;
  for (int axis = 0; axis < 3; ++axis)
    for (double side : {-1.0, 1.0}) {
      Eigen::Vector3d lo = Eigen::Vector3d::Constant(-h - 0.1), hi = Eigen::Vector3d::Constant(h + 0.1);
      (side > 0 ? lo : hi)[axis] = side * h;
      w.add(Box{lo, hi, {}});
    }
  w.build();
  return w;
}
}  // namespace

TEST(SimLidar, Spinning32InCampus) {
  const Scenario s = make_scenario("campus", 1, 1);
  const LidarConfig c = LidarConfig::spinning32();
  LidarSimulator sim(c, s.world, *s.trajectory, default_T_imu_lidar(), 1);
  const fuse::LidarScan scan = sim.scan(100, s.trajectory->t_begin());
  std::set<int> rings;
  int beyond_40 = 0;
  for (const fuse::LidarPoint& p : scan.points) {
    const double r = std::sqrt(double(p.x) * p.x + double(p.y) * p.y + double(p.z) * p.z);
    ASSERT_GE(r, c.blind_range_m);
    ASSERT_LE(r, c.max_range_m);
    beyond_40 += r > 40.0;
    rings.insert(p.ring);
  }
  EXPECT_GT(scan.points.size(), 20000u);  // upper beams see the sky: fewer than 57600
  EXPECT_LT(scan.points.size(), 57600u);
  EXPECT_GT(beyond_40, 100);
  EXPECT_EQ(rings.size(), 32u);
}

TEST(SimLidar, BlindZoneAndMaxRange) {
  const Trajectory tr(make_rounded_polyline({{{0, 0, 0}, 0}, {{-10, 0, 0}, 0}}), TimeLawConfig{}, MotionConfig{}, 0.0);
  const LidarConfig c = LidarConfig::mid360();  // frame 0 is during the static start
  // Walls at most 0.05 * sqrt(3) = 0.087 m away: everything is inside the 0.1 m blind zone.
  const World near = hollow_cube(0.05);
  EXPECT_EQ(LidarSimulator(c, near, tr, Eigen::Isometry3d::Identity(), 1).scan(0, 0.0).points.size(), 0u);
  // Walls at least 45 m away: everything is beyond the 40 m maximum range.
  const World far = hollow_cube(45.0);
  EXPECT_EQ(LidarSimulator(c, far, tr, Eigen::Isometry3d::Identity(), 1).scan(0, 0.0).points.size(), 0u);
  // Walls 20 m away: every shot returns.
  const World mid = hollow_cube(20.0);
  EXPECT_EQ(LidarSimulator(c, mid, tr, Eigen::Isometry3d::Identity(), 1).scan(0, 0.0).points.size(), 20000u);
}

TEST(SimLidar, PointsAreCastFromTheTruePoseAtTheirOwnTime) {
  const Scenario s = make_scenario("room", 4, 4);
  const Trajectory& tr = *s.trajectory;
  LidarConfig c = LidarConfig::mid360();
  c.range_noise_sigma_m = 0.0;
  c.angular_noise_sigma_rad = 0.0;
  const Eigen::Isometry3d T_il = default_T_imu_lidar();
  LidarSimulator sim(c, s.world, tr, T_il, 4);
  const std::uint64_t k = 200;  // 20 s in: aggressive rotation
  const fuse::LidarScan scan = sim.scan(k, tr.t_begin());
  ASSERT_GT(scan.points.size(), 19000u);
  const TrajectoryState start = tr.state(scan.t_start);
  double max_own = 0.0, max_start = 0.0;
  for (const fuse::LidarPoint& p : scan.points) {
    const Eigen::Vector3d pl(p.x, p.y, p.z);
    const TrajectoryState x = tr.state(scan.t_start + p.t_rel);
    const Eigen::Vector3d w_own = x.R * (T_il * pl) + x.p;
    const Eigen::Vector3d w_start = start.R * (T_il * pl) + start.p;
    max_own = std::max(max_own, s.world.clearance(w_own));
    max_start = std::max(max_start, s.world.clearance(w_start));
  }
  EXPECT_LT(max_own, 1e-4);  // float storage of the point only
  EXPECT_GT(max_start, 0.1);  // the frame-start pose would be wrong
}

// Scenario requirements: corridor loop length and closure, walking speeds, stairs climbing, room
// angular rates, campus length and speed, and which seed controls what.
#include <gtest/gtest.h>

#include <cmath>

#include "fuse/sim/scenario.hpp"

using namespace fuse::sim;

namespace {
struct Stats {
  double max_speed = 0, max_rate_deg = 0, cruise_speed = 0, climb = 0;
};
Stats stats(const Trajectory& tr) {
  Stats st;
  const double z0 = tr.state(tr.t_begin()).p.z();
  for (double t = tr.t_begin(); t <= tr.t_end(); t += 0.005) {
    const TrajectoryState x = tr.state(t);
    st.max_speed = std::max(st.max_speed, x.v.norm());
    st.max_rate_deg = std::max(st.max_rate_deg, x.omega_body.norm() * 180 / M_PI);
    st.climb = std::max(st.climb, x.p.z() - z0);
  }
  st.cruise_speed = tr.state(0.5 * (tr.t_begin() + tr.t_end())).v.norm();
  return st;
}
bool same_boxes(const World& a, const World& b) {
  if (a.boxes().size() != b.boxes().size()) return false;
  for (std::size_t i = 0; i < a.boxes().size(); ++i)
    if (a.boxes()[i].min != b.boxes()[i].min || a.boxes()[i].max != b.boxes()[i].max ||
        a.boxes()[i].material.reflectivity != b.boxes()[i].material.reflectivity)
      return false;
  return true;
}
}  // namespace

TEST(SimScenario, CorridorLoopLengthAndClosure) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const Scenario s = make_scenario("corridor", seed, seed);
    const Trajectory& tr = *s.trajectory;
    EXPECT_NEAR(tr.path().arc_length(), 418.0, 10.0);
    const TrajectoryState a = tr.state(tr.t_begin()), b = tr.state(tr.t_end());
    EXPECT_LT((a.p - b.p).norm(), 1e-9);
    EXPECT_LT(Eigen::AngleAxisd(a.R.transpose() * b.R).angle(), 1e-9);
    EXPECT_EQ(b.v.norm(), 0.0);
    const Stats st = stats(tr);
    EXPECT_GE(st.cruise_speed, 1.15);
    EXPECT_LE(st.max_speed, 1.5);
    EXPECT_GT(tr.t_end() - tr.t_begin(), 280.0);
    EXPECT_GT(std::count_if(s.parameters.begin(), s.parameters.end(),
                            [](const auto& kv) { return kv.first == "features" && kv.second >= 20; }),
              0);
  }
}

TEST(SimScenario, RoomPeakAngularRateAbove180DegPerSecond) {
  for (std::uint64_t seed : {1u, 2u, 3u, 4u}) {
    const Scenario s = make_scenario("room", 1, seed);
    const Stats st = stats(*s.trajectory);
    EXPECT_GT(st.max_rate_deg, 180.0) << "seed " << seed;
    const double d = s.trajectory->t_end() - s.trajectory->t_begin();
    EXPECT_GE(d, 30.0);
    EXPECT_LE(d, 60.0);
  }
}

TEST(SimScenario, StairsClimbThreeFloors) {
  const Scenario s = make_scenario("stairs", 1, 1);
  const Stats st = stats(*s.trajectory);
  EXPECT_NEAR(st.climb, 9.0, 0.1);
  EXPECT_LT(st.max_speed, 1.5);
  EXPECT_GT(s.trajectory->path().arc_length(), 40.0);
}

TEST(SimScenario, CampusAboutOneKilometreFast) {
  const Scenario s = make_scenario("campus", 1, 1);
  EXPECT_NEAR(s.trajectory->path().arc_length(), 1000.0, 100.0);
  const Stats st = stats(*s.trajectory);
  EXPECT_GE(st.cruise_speed, 3.0);
  EXPECT_LE(st.max_speed, 6.5);
  EXPECT_GT(s.world.boxes().size(), 100u);
}

TEST(SimScenario, WorldSeedFixesTheWorldSeedTheMotion) {
  const Scenario a = make_scenario("corridor", 5, 1), b = make_scenario("corridor", 5, 2);
  const Scenario c = make_scenario("corridor", 6, 1);
  EXPECT_TRUE(same_boxes(a.world, b.world));
  EXPECT_FALSE(same_boxes(a.world, c.world));
  const double t = a.trajectory->t_begin() + 30.0;
  EXPECT_GT((a.trajectory->state(t).p - b.trajectory->state(t).p).norm(), 1e-3);  // motion varies with --seed
  EXPECT_EQ((a.trajectory->state(t).p - c.trajectory->state(t).p).norm(), 0.0);   // not with the world seed
  EXPECT_THROW(make_scenario("mall", 1, 1), std::invalid_argument);
}

TEST(SimScenario, AWalkStartedAlongThePathIsInTheSameWorldAndFrame) {
  // --start-at: the same boxes, the walk starts at rest where the full path passes that far along,
  // and goes on along it; the other walk's motion is its own (--seed).
  const Scenario full = make_scenario("corridor", 3, 3), later = make_scenario("corridor", 3, 5, kStartTime, 1, 40.0);
  EXPECT_TRUE(same_boxes(full.world, later.world));
  const TrajectoryState s0 = later.trajectory->state(later.trajectory->t_begin());
  EXPECT_LT((s0.p - full.trajectory->path().at(40.0).c).norm(), 1e-9);
  EXPECT_LT(s0.v.norm(), 1e-12);  // at rest
  EXPECT_NEAR(later.trajectory->path().u_end(), full.trajectory->path().u_end() - 40.0, 1e-9);
  const double t_end = later.trajectory->t_end();
  EXPECT_LT((later.trajectory->state(t_end).p - full.trajectory->state(full.trajectory->t_end()).p).norm(), 1e-6);
  EXPECT_THROW(make_scenario("corridor", 3, 5, kStartTime, 1, 1e4), std::invalid_argument);
  EXPECT_THROW(make_scenario("corridor", 3, 5, kStartTime, 1, -1.0), std::invalid_argument);
}

TEST(SimScenario, ExtrinsicIsTheMid360OffsetWithASmallRotation) {
  const Eigen::Isometry3d T = default_T_imu_lidar();
  EXPECT_EQ(T.translation(), Eigen::Vector3d(-0.011, -0.02329, 0.04412));
  const double angle_deg = Eigen::AngleAxisd(T.linear()).angle() * 180 / M_PI;
  EXPECT_GT(angle_deg, 1.5);
  EXPECT_LT(angle_deg, 2.5);
}

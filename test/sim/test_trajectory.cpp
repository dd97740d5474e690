// Path and trajectory: continuity at the Hermite knots, exact derivatives (checked against
// central differences), static start and end, time law.
#include <gtest/gtest.h>

#include <cmath>

#include "fuse/sim/path.hpp"
#include "fuse/sim/scenario.hpp"
#include "fuse/sim/time_law.hpp"
#include "fuse/sim/trajectory.hpp"

using namespace fuse::sim;

namespace {
Eigen::Vector3d log_so3(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}
}  // namespace

TEST(SimPath, RoundedPolylineIsC3AndNearlyUnitSpeed) {
  const Path path = make_rounded_polyline(
      {{{0, 0, 1}, 0}, {{10, 0, 1}, 1.0}, {{10, 8, 1}, 1.5}, {{4, 8, 3}, 2.0}, {{0, 8, 3}, 0}});
  EXPECT_GT(path.num_pieces(), 6u);
  double u = 0.0;
  const double eps = 1e-7;
  // Every knot: left and right limits agree for c, c', c'', c'''.
  for (double probe = 0.05; probe < path.u_end(); probe += 0.05) {
    const PathPoint a = path.at(probe - eps), b = path.at(probe + eps);
    EXPECT_LT((a.c - b.c).norm(), 1e-5);
    EXPECT_LT((a.c1 - b.c1).norm(), 1e-5);
    EXPECT_LT((a.c2 - b.c2).norm(), 1e-4);
    EXPECT_LT((a.c3 - b.c3).norm(), 1e-3);
    const double speed = path.at(probe).c1.norm();
    EXPECT_GT(speed, 0.85);
    EXPECT_LT(speed, 1.15);
    u = probe;
  }
  EXPECT_GT(u, 20.0);
  EXPECT_NEAR((path.at(path.u_end()).c - Eigen::Vector3d(0, 8, 3)).norm(), 0.0, 1e-12);
  // Derivatives against central differences.
  for (double q : {0.3, 9.5, 10.2, 14.0, 19.0}) {
    const double h = 1e-5;
    const PathPoint p = path.at(q), pm = path.at(q - h), pp = path.at(q + h);
    EXPECT_LT((p.c1 - (pp.c - pm.c) / (2 * h)).norm(), 1e-6);
    EXPECT_LT((p.c2 - (pp.c1 - pm.c1) / (2 * h)).norm(), 1e-5);
    EXPECT_LT((p.c3 - (pp.c2 - pm.c2) / (2 * h)).norm(), 1e-4);
    const Heading hd = Path::heading(p), hm = Path::heading(pm), hp = Path::heading(pp);
    EXPECT_NEAR(hd.theta_u, (hp.theta - hm.theta) / (2 * h), 1e-6);
    EXPECT_NEAR(hd.theta_uu, (hp.theta_u - hm.theta_u) / (2 * h), 1e-5);
  }
}

TEST(SimPath, RejectsImpossibleCorners) {
  EXPECT_THROW(make_rounded_polyline({{{0, 0, 0}, 0}, {{1, 0, 0}, 5.0}, {{1, 1, 0}, 0}}), std::invalid_argument);
  EXPECT_THROW(make_rounded_polyline({{{0, 0, 0}, 0}}), std::invalid_argument);
  EXPECT_THROW(make_rounded_polyline({{{0, 0, 0}, 0}, {{5, 0, 0}, 1.0}, {{0, 0.1, 0}, 0}}), std::invalid_argument);
}

TEST(SimTimeLaw, RestRampCruiseStop) {
  TimeLawConfig c;
  c.rate = 1.3;
  const TimeLaw law(c, 50.0);
  EXPECT_EQ(law.at(0.0).u, 0.0);
  EXPECT_EQ(law.at(c.rest_start_s).u1, 0.0);
  EXPECT_NEAR(law.at(c.rest_start_s + c.ramp_s + 1.0).u1, 1.3, 1e-12);
  EXPECT_NEAR(law.at(law.duration()).u, 50.0, 1e-9);
  EXPECT_EQ(law.at(law.duration() - 0.5 * c.rest_end_s).u1, 0.0);
  for (double t = 0.01; t < law.duration(); t += 0.37) {  // derivatives vs central differences
    const double h = 1e-5;
    const TimeLawSample s = law.at(t), a = law.at(t - h), b = law.at(t + h);
    EXPECT_NEAR(s.u1, (b.u - a.u) / (2 * h), 1e-7);
    EXPECT_NEAR(s.u2, (b.u1 - a.u1) / (2 * h), 1e-6);
    EXPECT_NEAR(s.u3, (b.u2 - a.u2) / (2 * h), 1e-4);
  }
  EXPECT_THROW(TimeLaw(c, 1.0), std::invalid_argument);
}

TEST(SimTrajectory, DerivativesMatchFiniteDifferencesInEveryScenario) {
  for (const std::string& name : scenario_names()) {
    const Scenario s = make_scenario(name, 3, 4);
    const Trajectory& tr = *s.trajectory;
    const double h = 1e-5;
    for (double t = tr.t_begin() + 0.013; t < tr.t_end(); t += 1.7) {
      const TrajectoryState x = tr.state(t), a = tr.state(t - h), b = tr.state(t + h);
      EXPECT_LT((x.v - (b.p - a.p) / (2 * h)).norm(), 1e-6) << name << " t=" << t;
      EXPECT_LT((x.a - (b.v - a.v) / (2 * h)).norm(), 1e-5) << name << " t=" << t;
      const Eigen::Vector3d w = log_so3(a.R.transpose() * b.R) / (2 * h);
      EXPECT_LT((x.omega_body - w).norm(), 1e-6) << name << " t=" << t;
      EXPECT_NEAR((x.R.transpose() * x.R - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-12);
    }
  }
}

// The corridor walked twice: twice the path through the same world, and half-way (one lap on)
// the walker passes the start again.
TEST(SimTrajectory, CorridorLapsGoRoundTheSameLoopAgain) {
  const Scenario one = make_scenario("corridor", 2, 2);
  const Scenario two = make_scenario("corridor", 2, 2, kStartTime, 2);
  const double length = one.trajectory->path().arc_length();
  EXPECT_NEAR(two.trajectory->path().arc_length(), 2.0 * length, 1e-6 * length);
  const Eigen::Vector3d start = two.trajectory->state(two.trajectory->t_begin()).p;
  double closest = 1e9;
  for (double t = two.trajectory->t_begin() + 60.0; t < two.trajectory->t_end() - 60.0; t += 0.05) {
    closest = std::min(closest, (two.trajectory->state(t).p - start).norm());
  }
  EXPECT_LT(closest, 0.1) << "the second lap passes the start";
  EXPECT_THROW(make_scenario("room", 1, 1, kStartTime, 2), std::invalid_argument);
}

TEST(SimTrajectory, StaticStartAndEndAtRest) {
  for (const std::string& name : scenario_names()) {
    const Scenario s = make_scenario(name, 1, 1);
    const Trajectory& tr = *s.trajectory;
    const TrajectoryState first = tr.state(tr.t_begin());
    for (double dt = 0.0; dt <= 2.5; dt += 0.005) {
      const TrajectoryState x = tr.state(tr.t_begin() + dt);
      ASSERT_EQ(x.v.norm(), 0.0) << name;
      ASSERT_EQ(x.a.norm(), 0.0) << name;
      ASSERT_EQ(x.omega_body.norm(), 0.0) << name;
      ASSERT_EQ((x.p - first.p).norm(), 0.0) << name;
      ASSERT_EQ((x.R - first.R).norm(), 0.0) << name;
    }
    const TrajectoryState last = tr.state(tr.t_end());
    EXPECT_EQ(last.v.norm(), 0.0) << name;
    EXPECT_EQ(last.omega_body.norm(), 0.0) << name;
    EXPECT_GT(tr.state(0.5 * (tr.t_begin() + tr.t_end())).v.norm(), 0.2) << name;
  }
}

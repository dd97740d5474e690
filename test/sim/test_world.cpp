// Ray casting: analytic ray-box / ray-plane cases, the BVH against brute force, and the
// trajectories staying in free space.
#include <gtest/gtest.h>

#include <cmath>

#include "fuse/sim/random.hpp"
#include "fuse/sim/scenario.hpp"
#include "fuse/sim/world.hpp"

using namespace fuse::sim;

TEST(SimWorld, RayBoxAnalytic) {
  Box b;
  b.min = {2, -1, -1};
  b.max = {3, 1, 1};
  Hit h = intersect(b, {0, 0, 0}, {1, 0, 0});
  ASSERT_TRUE(h.valid());
  EXPECT_DOUBLE_EQ(h.range, 2.0);
  EXPECT_EQ(h.normal, Eigen::Vector3d(-1, 0, 0));
  // Oblique ray through the face x = 2 at (2, 0.5, 0.5): range = |(2, .5, .5)|.
  const Eigen::Vector3d d = Eigen::Vector3d(2, 0.5, 0.5).normalized();
  h = intersect(b, {0, 0, 0}, d);
  ASSERT_TRUE(h.valid());
  EXPECT_NEAR(h.range, std::sqrt(4.5), 1e-12);
  // Misses: pointing away, passing beside, parallel outside a slab.
  EXPECT_FALSE(intersect(b, {0, 0, 0}, {-1, 0, 0}).valid());
  EXPECT_FALSE(intersect(b, {0, 0, 0}, Eigen::Vector3d(1, 1, 0).normalized()).valid());
  EXPECT_FALSE(intersect(b, {0, 2, 0}, {1, 0, 0}).valid());
  // Hitting the top face from above.
  h = intersect(b, {2.5, 0, 5}, {0, 0, -1});
  EXPECT_DOUBLE_EQ(h.range, 4.0);
  EXPECT_EQ(h.normal, Eigen::Vector3d(0, 0, 1));
  // Inside: blocked at range 0.
  EXPECT_EQ(intersect(b, {2.5, 0, 0}, {1, 0, 0}).range, 0.0);
}

TEST(SimWorld, RayPlaneAnalytic) {
  const Plane p{Eigen::Vector3d::UnitZ(), 3.0, {}};
  const Eigen::Vector3d d = Eigen::Vector3d(1, 0, 1).normalized();
  const Hit h = intersect(p, {0, 0, 1}, d);
  ASSERT_TRUE(h.valid());
  EXPECT_NEAR(h.range, 2.0 * std::sqrt(2.0), 1e-12);
  EXPECT_EQ(h.normal, Eigen::Vector3d(0, 0, -1));
  EXPECT_FALSE(intersect(p, {0, 0, 1}, {0, 0, -1}).valid());
  EXPECT_FALSE(intersect(p, {0, 0, 1}, {1, 0, 0}).valid());
}

TEST(SimWorld, BvhMatchesBruteForceInEveryScenario) {
  for (const std::string& name : scenario_names()) {
    const Scenario s = make_scenario(name, 8, 8);
    const Trajectory& tr = *s.trajectory;
    Rng rng(1, Stream::kLidar);
    int hits = 0;
    for (int i = 0; i < 20000; ++i) {
      const double t = rng.uniform(tr.t_begin(), tr.t_end());
      const Eigen::Vector3d o = tr.state(t).p;
      Eigen::Vector3d d(rng.normal(), rng.normal(), rng.normal());
      d.normalize();
      const Hit a = s.world.cast(o, d, 60.0), b = s.world.cast_brute_force(o, d, 60.0);
      ASSERT_EQ(a.valid(), b.valid()) << name;
      if (!a.valid()) continue;
      ++hits;
      ASSERT_NEAR(a.range, b.range, 1e-12) << name;
      // (overlapping boxes may tie at the same range, so the surface hit first may differ)
      // The hit point lies on the surface of a box or a plane: clearance ~ 0.
      ASSERT_LT(s.world.clearance(o + a.range * d), 1e-9) << name;
    }
    EXPECT_GT(hits, 10000) << name;
  }
}

TEST(SimWorld, TrajectoriesStayInFreeSpace) {
  for (const std::string& name : scenario_names()) {
    for (std::uint64_t world_seed : {1u, 2u, 3u}) {
      const Scenario s = make_scenario(name, world_seed, world_seed + 10);
      const Trajectory& tr = *s.trajectory;
      double min_clearance = 1e9;
      for (double t = tr.t_begin(); t <= tr.t_end(); t += 0.1)
        min_clearance = std::min(min_clearance, s.world.clearance(tr.state(t).p));
      EXPECT_GT(min_clearance, 0.3) << name << " world seed " << world_seed;
    }
  }
}

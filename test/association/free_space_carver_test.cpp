// Free-space carving (free_space_carver.hpp) on scenes whose truth is known: what a ray passes
// through is carved, what it ends on or grazes is kept, a surface hit again and again leaves
// probation, and the work per scan is bounded.
#include "fuse/map/free_space_carver.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "fuse/map/map_policy.hpp"

#include "../core/config_checks.hpp"

namespace fuse {
namespace {

/// Points of the rectangle spanned from corner by edges a and b, every `step` m.
std::vector<Eigen::Vector3f> patch(const Eigen::Vector3f& corner, const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                   float step) {
  std::vector<Eigen::Vector3f> out;
  const int na = static_cast<int>(std::round(a.norm() / step)), nb = static_cast<int>(std::round(b.norm() / step));
  for (int i = 0; i <= na; ++i) {
    for (int j = 0; j <= nb; ++j) {
      out.push_back(corner + a * (static_cast<float>(i) / static_cast<float>(na)) +
                    b * (static_cast<float>(j) / static_cast<float>(nb)));
    }
  }
  return out;
}

struct Scene {
  std::unique_ptr<SpatialIndex> map = make_spatial_index(SpatialIndexConfig{});
  void insert(FreeSpaceCarver& carver, double t, const std::vector<Eigen::Vector3f>& pts) {
    map->insert(pts);
    carver.add(t, pts);
  }
};

std::size_t count_within(const std::vector<Eigen::Vector3f>& pts, const std::vector<Eigen::Vector3f>& of) {
  return static_cast<std::size_t>(std::count_if(pts.begin(), pts.end(), [&](const Eigen::Vector3f& p) {
    return std::find(of.begin(), of.end(), p) != of.end();
  }));
}

// A car-sized patch at x = 10 in front of a wall at x = 20, both mapped at t = 0; the car has
// gone at t = 0.1 and the scan from the origin sees the wall through where it was: every car
// point is carved, no wall point.
TEST(FreeSpaceCarver, WhatTheRaysPassThroughIsCarvedWhatTheyEndOnIsKept) {
  CarveConfig cfg;
  cfg.probation_s = 2.0;
  FreeSpaceCarver carver(cfg);
  Scene scene;
  const auto car = patch({10.0f, -1.0f, -0.5f}, {0.0f, 2.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, 0.1f);
  const auto wall = patch({20.0f, -4.0f, -2.0f}, {0.0f, 8.0f, 0.0f}, {0.0f, 0.0f, 4.0f}, 0.05f);
  scene.insert(carver, 0.0, car);
  scene.insert(carver, 0.0, wall);
  const std::vector<Eigen::Vector3f> origins(wall.size(), Eigen::Vector3f::Zero());
  const auto& carved = carver.carve(0.1, wall, origins, *scene.map);
  EXPECT_EQ(carved.size(), car.size());
  EXPECT_EQ(count_within(carved, car), car.size());
  EXPECT_EQ(count_within(carved, wall), 0u);
  EXPECT_EQ(carver.on_probation(), wall.size());
}

// Rays that meet a surface at a shallow angle run within carve_radius of its points long before
// they end: the ground ahead of a sensor 1.9 m up, and a corridor's wall 1 m to the side. Neither
// is carved, by many scans of such rays.
TEST(FreeSpaceCarver, SurfacesSeenEdgeOnAreNotCarved) {
  CarveConfig cfg;
  cfg.probation_s = 10.0;
  cfg.radius = 0.2;
  FreeSpaceCarver carver(cfg);
  Scene scene;
  const auto ground = patch({2.0f, -3.0f, 0.0f}, {40.0f, 0.0f, 0.0f}, {0.0f, 3.8f, 0.0f}, 0.2f);  // up to the wall
  const auto wall = patch({0.0f, 1.0f, 0.0f}, {30.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 2.5f}, 0.1f);
  scene.insert(carver, 0.0, ground);
  scene.insert(carver, 0.0, wall);
  const Eigen::Vector3f o(0.0f, 0.0f, 1.9f);
  std::vector<Eigen::Vector3f> ends = ground;
  ends.insert(ends.end(), wall.begin(), wall.end());
  for (int scan = 1; scan <= 10; ++scan) {
    const std::vector<Eigen::Vector3f> origins(ends.size(), o);
    EXPECT_TRUE(carver.carve(0.1 * scan, ends, origins, *scene.map).empty()) << "scan " << scan;
  }
  // The wall is a plane, and a ray that ends on it does not end behind it: even without the
  // grazing test, the plane test keeps it. Its margin alone would not: the same wall as a
  // scatter of points (no plane within reach) is carved by these rays.
  cfg.min_incidence_deg = 0.0;
  FreeSpaceCarver careless(cfg);
  Scene again;
  again.insert(careless, 0.0, wall);
  const std::vector<Eigen::Vector3f> origins(wall.size(), o);
  EXPECT_TRUE(careless.carve(0.1, wall, origins, *again.map).empty());
  FreeSpaceCarver scattered(cfg);
  Scene sparse;
  const auto posts = patch({0.0f, 1.0f, 0.0f}, {30.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 2.4f}, 0.6f);
  sparse.insert(scattered, 0.0, posts);
  const std::vector<Eigen::Vector3f> post_origins(posts.size(), o);
  EXPECT_FALSE(scattered.carve(0.1, posts, post_origins, *sparse.map).empty());
}

// The side of a car a metre in front of a wall 20 m away, mapped with the wall at t = 0, has
// gone at t = 0.1, and the rays end on the wall 1 m behind it. The side is a plane the rays cross
// and end 1 m behind: carved. A small thing at the same place (a bollard's three points, no plane)
// needs the margin (the wall 0.15 × 19 + 0.5 m behind it) and is kept. No wall point is carved.
TEST(FreeSpaceCarver, APlaneTheRaysGoThroughIsCarvedWithoutTheMargin) {
  CarveConfig cfg;
  cfg.probation_s = 2.0;
  FreeSpaceCarver carver(cfg);
  Scene scene;
  const auto side = patch({19.0f, -1.0f, -0.8f}, {0.0f, 0.8f, 0.0f}, {0.0f, 0.0f, 1.6f}, 0.1f);
  const std::vector<Eigen::Vector3f> bollard = {{19.0f, 1.5f, 0.0f}, {19.0f, 1.5f, 0.3f}, {19.1f, 1.6f, 0.6f}};
  const auto wall = patch({20.0f, -4.0f, -2.0f}, {0.0f, 8.0f, 0.0f}, {0.0f, 0.0f, 4.0f}, 0.05f);
  scene.insert(carver, 0.0, side);
  scene.insert(carver, 0.0, bollard);
  scene.insert(carver, 0.0, wall);
  const std::vector<Eigen::Vector3f> origins(wall.size(), Eigen::Vector3f::Zero());
  const auto& carved = carver.carve(0.1, wall, origins, *scene.map);
  EXPECT_EQ(carved.size(), side.size());
  EXPECT_EQ(count_within(carved, side), side.size());
  EXPECT_EQ(count_within(carved, bollard), 0u);
  EXPECT_EQ(count_within(carved, wall), 0u);
}

// A corridor 2 m wide and 2.5 m high, all of it young, seen from its middle: rays end on the
// floor, the side walls and the far wall, and run close to the floor at the foot of the walls
// and along the walls. None of them goes through a surface: nothing is carved.
TEST(FreeSpaceCarver, RaysEndingAtTheFootOfAWallDoNotCarveTheFloor) {
  CarveConfig cfg;
  cfg.probation_s = 10.0;
  FreeSpaceCarver carver(cfg);
  Scene scene;
  std::vector<Eigen::Vector3f> ends = patch({1.0f, -0.9f, 0.0f}, {30.0f, 0.0f, 0.0f}, {0.0f, 1.8f, 0.0f}, 0.1f);
  for (const auto& part : {patch({1.0f, 1.0f, 0.1f}, {30.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 2.4f}, 0.1f),
                           patch({1.0f, -1.0f, 0.1f}, {30.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 2.4f}, 0.1f),
                           patch({31.0f, -1.0f, 0.0f}, {0.0f, 2.0f, 0.0f}, {0.0f, 0.0f, 2.5f}, 0.1f)}) {
    ends.insert(ends.end(), part.begin(), part.end());
  }
  scene.insert(carver, 0.0, ends);
  const std::vector<Eigen::Vector3f> origins(ends.size(), Eigen::Vector3f(0.0f, 0.0f, 1.2f));
  for (int scan = 1; scan <= 5; ++scan) EXPECT_TRUE(carver.carve(0.1 * scan, ends, origins, *scene.map).empty()) << scan;
}

// A surface that later scans keep hitting leaves probation after release_s, untested; points
// older than probation_s leave it as well, and neither is carved afterwards.
TEST(FreeSpaceCarver, ASurfaceHitAgainLeavesProbationAndOldPointsAreSafe) {
  CarveConfig cfg;
  cfg.probation_s = 1.0;
  cfg.release_s = 0.3;
  FreeSpaceCarver carver(cfg);
  Scene scene;
  const auto wall = patch({20.0f, -4.0f, -2.0f}, {0.0f, 8.0f, 0.0f}, {0.0f, 0.0f, 4.0f}, 0.1f);
  const auto post = patch({10.0f, 6.0f, -0.5f}, {0.0f, 0.2f, 0.0f}, {0.0f, 0.0f, 1.0f}, 0.1f);  // beside the wall
  scene.insert(carver, 0.0, wall);
  scene.insert(carver, 0.0, post);
  // Scans that hit the wall and the post: both keep being seen, nothing passes through either.
  std::vector<Eigen::Vector3f> ends = wall;
  ends.insert(ends.end(), post.begin(), post.end());
  const std::vector<Eigen::Vector3f> origins(ends.size(), Eigen::Vector3f::Zero());
  for (int scan = 1; scan <= 4; ++scan) EXPECT_TRUE(carver.carve(0.1 * scan, ends, origins, *scene.map).empty());
  EXPECT_EQ(carver.on_probation(), 0u);
  EXPECT_EQ(carver.released(), wall.size() + post.size());
  // A pole mapped at 0.5 and then not seen again: at 1.6 it is past probation, and a ray
  // through it changes nothing.
  const auto pole = patch({10.0f, 2.0f, -0.5f}, {0.0f, 0.2f, 0.0f}, {0.0f, 0.0f, 1.0f}, 0.1f);
  scene.insert(carver, 0.5, pole);
  const std::vector<Eigen::Vector3f> wall_origins(wall.size(), Eigen::Vector3f::Zero());
  EXPECT_TRUE(carver.carve(1.6, wall, wall_origins, *scene.map).empty());
  EXPECT_EQ(carver.on_probation(), 0u);
}

// Scans that carve nothing (a pose not trusted) still age the points: probation ends on time.
TEST(FreeSpaceCarver, ProbationEndsWithoutCarvingScans) {
  CarveConfig cfg;
  cfg.probation_s = 2.0;
  FreeSpaceCarver carver(cfg);
  carver.add(0.0, {Eigen::Vector3f(1, 2, 3), Eigen::Vector3f(4, 5, 6)});
  carver.add(1.0, {Eigen::Vector3f(7, 8, 9)});
  EXPECT_EQ(carver.on_probation(), 3u);
  carver.add(2.5, {});
  EXPECT_EQ(carver.on_probation(), 1u);
  carver.add(3.5, {});
  EXPECT_EQ(carver.on_probation(), 0u);
}

// At most max_tests young points are tested per scan, in turn: 100 carvable points with a
// budget of 10 are carved 10 per scan, all of them within 10 scans.
TEST(FreeSpaceCarver, WorkPerScanIsBoundedAndEveryPointGetsItsTurn) {
  CarveConfig cfg;
  cfg.probation_s = 5.0;
  cfg.max_tests = 10;
  FreeSpaceCarver carver(cfg);
  Scene scene;
  const auto car = patch({10.0f, -0.45f, -0.45f}, {0.0f, 0.9f, 0.0f}, {0.0f, 0.0f, 0.9f}, 0.1f);
  ASSERT_EQ(car.size(), 100u);
  scene.insert(carver, 0.0, car);
  const auto wall = patch({20.0f, -2.0f, -2.0f}, {0.0f, 4.0f, 0.0f}, {0.0f, 0.0f, 4.0f}, 0.05f);
  const std::vector<Eigen::Vector3f> origins(wall.size(), Eigen::Vector3f::Zero());
  std::size_t total = 0;
  for (int scan = 1; scan <= 10; ++scan) {
    const std::size_t n = carver.carve(0.1 * scan, wall, origins, *scene.map).size();
    EXPECT_LE(n, 10u) << "scan " << scan;
    total += n;
  }
  EXPECT_EQ(total, car.size());
}

// The mapping policy with carve_s: a scan with its rays' origins takes the carved points out of
// the map and counts them; without origins (a scan whose pose is not trusted) it carves nothing.
TEST(FreeSpaceCarver, TheMappingPolicyCarvesOnlyWithTheRaysOrigins) {
  MapPolicyConfig cfg;
  cfg.min_point_distance = 0.0;
  cfg.carve_s = 2.0;
  auto policy = make_map_policy(cfg);
  auto map = make_spatial_index(SpatialIndexConfig{});
  const auto car = patch({10.0f, -1.0f, -0.5f}, {0.0f, 2.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, 0.1f);
  // 0.1 m apart: a 0.5 m voxel holds all of them (max_points_per_voxel 64).
  const auto wall = patch({20.0f, -4.0f, -2.0f}, {0.0f, 8.0f, 0.0f}, {0.0f, 0.0f, 4.0f}, 0.1f);
  EXPECT_EQ(policy->apply(0.0, car, *map).inserted, car.size());
  EXPECT_EQ(policy->apply(0.05, wall, *map, nullptr, nullptr, nullptr).carved, 0u);
  EXPECT_EQ(map->size(), car.size() + wall.size());
  const std::vector<Eigen::Vector3f> origins(wall.size(), Eigen::Vector3f::Zero());
  const MapUpdateStats stats = policy->apply(0.1, wall, *map, nullptr, nullptr, &origins);
  EXPECT_EQ(stats.carved, car.size());
  std::size_t car_left = 0;
  map->for_each_point([&](const Eigen::Vector3f& p) { car_left += p.x() < 15.0f ? 1 : 0; });
  EXPECT_EQ(car_left, 0u);
  EXPECT_EQ(map->size(), wall.size() + stats.inserted);
}

// Looking back (lookback_s): a wall at x = 20 was seen from the origin at t = 0. At t = 0.1 a car
// stands at x = 10, where those rays went through; the wall is seen again a little to the side,
// and a patch behind the wall is new: the car's points are marked, the wall's and what lies
// behind the wall are not. Scans at or after t, and scans older than lookback_s, mark nothing;
// nor does any scan mark a point the map has a point beside.
TEST(FreeSpaceCarver, PointsInSpaceAnEarlierScanSawEmptyAreMarked) {
  CarveConfig cfg;
  cfg.lookback_s = 1.0;  // no probation: looking back works alone
  FreeSpaceCarver carver(cfg);
  Scene scene;
  const auto wall = patch({20.0f, -4.0f, -2.0f}, {0.0f, 8.0f, 0.0f}, {0.0f, 0.0f, 4.0f}, 0.1f);
  scene.map->insert(wall);
  const auto car = patch({10.0f, -1.0f, -0.5f}, {0.0f, 2.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, 0.1f);
  const auto wall_again = patch({20.0f, -3.95f, -1.95f}, {0.0f, 7.9f, 0.0f}, {0.0f, 0.0f, 3.9f}, 0.1f);
  const auto behind = patch({25.0f, -1.0f, -0.5f}, {0.0f, 2.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, 0.1f);
  std::vector<Eigen::Vector3f> scan = car;
  scan.insert(scan.end(), wall_again.begin(), wall_again.end());
  scan.insert(scan.end(), behind.begin(), behind.end());
  std::vector<std::uint8_t> empty;
  EXPECT_EQ(carver.seen_empty(0.1, scan, *scene.map, empty), 0u) << "no scan remembered yet";

  const std::vector<Eigen::Vector3f> origins(wall.size(), Eigen::Vector3f::Zero());
  EXPECT_TRUE(carver.carve(0.0, wall, origins, *scene.map).empty());
  EXPECT_EQ(carver.seen_empty(0.0, scan, *scene.map, empty), 0u) << "a scan of the same time";
  EXPECT_EQ(carver.seen_empty(0.1, scan, *scene.map, empty), car.size());
  ASSERT_EQ(empty.size(), scan.size());
  for (std::size_t i = 0; i < scan.size(); ++i) EXPECT_EQ(empty[i] != 0, i < car.size()) << "point " << i;
  EXPECT_EQ(carver.seen_empty(1.05, scan, *scene.map, empty), 0u) << "older than lookback_s";
  // A point with a map point beside it is where the map says something is: not judged.
  scene.map->insert(car);
  EXPECT_EQ(carver.seen_empty(0.1, scan, *scene.map, empty), 0u) << "the car is in the map";
}

// The mapping policy marks moving points only with carve_lookback_s, and only from the rays of
// scans given with their origins (trusted ones).
TEST(FreeSpaceCarver, TheMappingPolicyMarksWhatAnEarlierTrustedScanSawEmpty) {
  const auto wall = patch({20.0f, -4.0f, -2.0f}, {0.0f, 8.0f, 0.0f}, {0.0f, 0.0f, 4.0f}, 0.1f);
  const auto car = patch({10.0f, -1.0f, -0.5f}, {0.0f, 2.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, 0.1f);
  const std::vector<Eigen::Vector3f> origins(wall.size(), Eigen::Vector3f::Zero());
  for (const double lookback : {0.0, 1.0}) {
    for (const bool trusted : {true, false}) {
      MapPolicyConfig cfg;
      cfg.carve_lookback_s = lookback;
      auto policy = make_map_policy(cfg);
      EXPECT_EQ(policy->marks_moving(), lookback > 0.0);
      auto map = make_spatial_index(SpatialIndexConfig{});
      policy->apply(0.0, wall, *map, nullptr, nullptr, trusted ? &origins : nullptr);
      std::vector<std::uint8_t> moving;
      const bool marks = lookback > 0.0 && trusted;
      EXPECT_EQ(policy->mark_moving(0.1, car, *map, moving), marks ? car.size() : 0u)
          << "lookback " << lookback << (trusted ? ", trusted" : ", untrusted");
      EXPECT_EQ(moving.size(), car.size());
    }
  }
  LocalizationPolicy localization;
  EXPECT_FALSE(localization.marks_moving());
}

TEST(FreeSpaceCarver, BadCarveKeysStopWithTheKeyNamed) {
  expect_refused_naming_the_key<MapPolicyConfig>({"carve_s: -1\n", "carve_radius: 0\n", "carve_beyond: 2\n",
                                                   "carve_margin: -0.1\n", "carve_tests: 0\n", "carve_release_s: 0\n",
                                                   "carve_min_incidence_deg: 90\n", "carve_plane_gap: 0\n",
                                                   "carve_lookback_s: -1\n", "carve_lookback_s: 6\n", "carve_lookback_tests: 0\n"});
}

}  // namespace
}  // namespace fuse

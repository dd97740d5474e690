// Map policies (map_policy.hpp): mapping inserts points unless the map already has one within
// min_point_distance, and with confirm_s only once their place has persisted; localization never
// changes the map.
#include "fuse/map/map_policy.hpp"

#include <gtest/gtest.h>

#include "../core/config_checks.hpp"

namespace fuse {
namespace {

std::unique_ptr<SpatialIndex> map_with_origin() {
  auto map = make_spatial_index(SpatialIndexConfig{});
  map->insert({Eigen::Vector3f::Zero()});
  return map;
}

TEST(MapPolicy, MappingSkipsPointsCloseToTheMap) {
  MapPolicyConfig cfg;
  cfg.min_point_distance = 0.25;
  auto map = map_with_origin();
  auto policy = make_map_policy(cfg);
  EXPECT_EQ(policy->name(), "mapping");
  const MapUpdateStats stats = policy->apply(0.0, {Eigen::Vector3f(0.1f, 0, 0),     // 0.1 m: skipped
                                              Eigen::Vector3f(0, 0.2f, 0.1f),  // 0.22 m: skipped
                                              Eigen::Vector3f(0.5f, 0, 0),     // 0.5 m: inserted
                                              Eigen::Vector3f(3, 3, 3)},       // far: inserted
                                             *map);
  EXPECT_EQ(stats.offered, 4u);
  EXPECT_EQ(stats.inserted, 2u);
  EXPECT_EQ(map->size(), 3u);
}

TEST(MapPolicy, MappingWithZeroDistanceInsertsEverything) {
  MapPolicyConfig cfg;
  cfg.min_point_distance = 0.0;
  auto map = map_with_origin();
  EXPECT_EQ(make_map_policy(cfg)->apply(0.0, {Eigen::Vector3f::Zero(), Eigen::Vector3f(0.01f, 0, 0)}, *map).inserted, 2u);
  EXPECT_EQ(map->size(), 3u);
}

TEST(MapPolicy, LocalizationNeverChangesTheMap) {
  MapPolicyConfig cfg;
  cfg.mode = "localization";
  auto map = map_with_origin();
  auto policy = make_map_policy(cfg);
  EXPECT_EQ(policy->name(), "localization");
  const MapUpdateStats stats = policy->apply(0.0, {Eigen::Vector3f(5, 5, 5), Eigen::Vector3f(-5, 0, 0)}, *map);
  EXPECT_EQ(stats.offered, 2u);
  EXPECT_EQ(stats.inserted, 0u);
  EXPECT_EQ(map->size(), 1u);
}

/// A wall at x = 10 (a 1 m patch of points) and a pedestrian walking along y at 1.5 m/s, scanned
/// at 10 Hz for 3 s with confirm_s = 1: the wall enters the map once it has been seen for 1 s, no
/// point of the walker ever does.
TEST(MapPolicy, OnlyPlacesThatPersistAreMapped) {
  MapPolicyConfig cfg;
  cfg.confirm_s = 1.0;
  cfg.confirm_cell = 0.5;
  cfg.confirm_forget_s = 1.0;
  auto map = map_with_origin();
  MappingPolicy policy(cfg);
  policy.apply(-5.0, {}, *map);  // the map was seeded long ago
  std::vector<Eigen::Vector3f> inserted;
  std::size_t walker_points = 0;
  for (int k = 0; k <= 30; ++k) {
    const double t = 0.1 * k;
    std::vector<Eigen::Vector3f> scan;
    for (int i = 0; i < 4; ++i) scan.emplace_back(10.0f, 0.3f * static_cast<float>(i), 1.0f);  // the wall
    for (int i = 0; i < 3; ++i) scan.emplace_back(5.0f, 1.5f * static_cast<float>(t), 0.5f * static_cast<float>(i));
    const MapUpdateStats stats = policy.apply(t, scan, *map, nullptr, &inserted);
    for (const Eigen::Vector3f& p : inserted) {
      if (p.x() == 5.0f) ++walker_points;
      if (p.x() == 10.0f) {
        EXPECT_GE(t, 1.0 - 1e-9) << "the wall went in before it had been seen for confirm_s";
      }
    }
    if (k < 10) {
      EXPECT_EQ(stats.inserted, 0u) << "t=" << t;
      EXPECT_EQ(stats.pending, 7u) << "t=" << t;
    }
  }
  EXPECT_EQ(walker_points, 0u);
  Neighbors nb;
  map->knn(Eigen::Vector3f(10.0f, 0.45f, 1.0f), 1, 0.3f, nb);
  EXPECT_EQ(nb.count, 1) << "the wall is in the map";
  EXPECT_LT(policy.places_pending(), 20u) << "places the walker left are forgotten";
}

TEST(MapPolicy, APlaceNotSeenAgainForTheForgetTimeStartsOver) {
  MapPolicyConfig cfg;
  cfg.confirm_s = 1.0;
  cfg.confirm_forget_s = 0.5;
  auto map = map_with_origin();
  MappingPolicy policy(cfg);
  policy.apply(-5.0, {}, *map);  // the map was seeded long ago
  const std::vector<Eigen::Vector3f> p{Eigen::Vector3f(4, 4, 0)};
  // Seen at 0, 0.4, 0.8 (a run), then at 1.6: 0.8 s unseen breaks the run; seen through to 2.6.
  for (double t : {0.0, 0.4, 0.8, 1.6, 2.0, 2.4}) EXPECT_EQ(policy.apply(t, p, *map).inserted, 0u) << t;
  EXPECT_EQ(policy.apply(2.6, p, *map).inserted, 1u);
}

TEST(MapPolicy, TheFirstConfirmPeriodSeedsAnEmptyMapAtOnce) {
  MapPolicyConfig cfg;
  cfg.confirm_s = 1.0;
  cfg.min_point_distance = 0.0;
  auto map = make_spatial_index(SpatialIndexConfig{});
  MappingPolicy policy(cfg);
  EXPECT_EQ(policy.apply(10.0, {Eigen::Vector3f(1, 0, 0), Eigen::Vector3f(2, 0, 0)}, *map).inserted, 2u);
  EXPECT_EQ(policy.apply(10.9, {Eigen::Vector3f(3, 0, 0)}, *map).inserted, 1u);
  EXPECT_EQ(policy.apply(11.1, {Eigen::Vector3f(4, 0, 0)}, *map).pending, 1u);
}

TEST(MapPolicy, BadConfirmValuesAreRefusedNamingTheKey) {
  expect_refused_naming_the_key<MapPolicyConfig>(
      {"confirm_s: -1\n", "confirm_s: 31\n", "confirm_cell: 0\n", "confirm_forget_s: 0\n"});
}

TEST(MapPolicy, UsesRaysOnlyWhenItCarves) {
  // The updater computes each point's ray origin (a second rotation per point) only for a policy
  // that reads them.
  MapPolicyConfig cfg;
  EXPECT_FALSE(make_map_policy(cfg)->uses_rays());
  cfg.carve_s = 2.0;
  EXPECT_TRUE(make_map_policy(cfg)->uses_rays());
  cfg.carve_s = 0.0;
  cfg.carve_lookback_s = 1.0;
  EXPECT_TRUE(make_map_policy(cfg)->uses_rays());
  cfg.mode = "localization";
  EXPECT_FALSE(make_map_policy(cfg)->uses_rays());
}

TEST(MapPolicy, UnknownModeIsRefused) {
  MapPolicyConfig cfg;
  ConfigNode node = ConfigNode::from_string("mode: painting\n");
  EXPECT_THROW(cfg.load(node), ConfigError);
}

}  // namespace
}  // namespace fuse

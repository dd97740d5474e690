// Map policies (map_policy.hpp): mapping inserts points unless the map already has one within
// min_point_distance; localization never changes the map.
#include "fuse/map/map_policy.hpp"

#include <gtest/gtest.h>

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
  const MapUpdateStats stats = policy->apply({Eigen::Vector3f(0.1f, 0, 0),     // 0.1 m: skipped
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
  EXPECT_EQ(make_map_policy(cfg)->apply({Eigen::Vector3f::Zero(), Eigen::Vector3f(0.01f, 0, 0)}, *map).inserted, 2u);
  EXPECT_EQ(map->size(), 3u);
}

TEST(MapPolicy, LocalizationNeverChangesTheMap) {
  MapPolicyConfig cfg;
  cfg.mode = "localization";
  auto map = map_with_origin();
  auto policy = make_map_policy(cfg);
  EXPECT_EQ(policy->name(), "localization");
  const MapUpdateStats stats = policy->apply({Eigen::Vector3f(5, 5, 5), Eigen::Vector3f(-5, 0, 0)}, *map);
  EXPECT_EQ(stats.offered, 2u);
  EXPECT_EQ(stats.inserted, 0u);
  EXPECT_EQ(map->size(), 1u);
}

TEST(MapPolicy, UnknownModeIsRefused) {
  MapPolicyConfig cfg;
  ConfigNode node = ConfigNode::from_string("mode: painting\n");
  EXPECT_THROW(cfg.load(node), ConfigError);
}

}  // namespace
}  // namespace fuse

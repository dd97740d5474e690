// Functional role (DESIGN §1): decides whether accepted observations change the map.
//   mapping:      insert/refine: a point is added unless the map already has a point within
//                 `min_point_distance` of it (keeps density bounded where the map is complete);
//   localization: the map is fixed; observations only serve association.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "fuse/association/spatial_index.hpp"
#include "fuse/core/config.hpp"

namespace fuse {

struct MapPolicyConfig {
  std::string mode = "mapping";      ///< mapping | localization
  double min_point_distance = 0.25;  ///< m, mapping: skip a point this close to an existing one
  void load(ConfigNode& node);
};

struct MapUpdateStats {
  std::size_t offered = 0;
  std::size_t inserted = 0;
};

class MapPolicy {
 public:
  virtual ~MapPolicy() = default;
  /// nearest_dist2 (optional, one per point): squared distance of each point to its nearest map
  /// point, when the association has just measured it; saves searching the map again.
  /// inserted (optional): receives the points the policy inserted into the map (cleared first).
  virtual MapUpdateStats apply(const std::vector<Eigen::Vector3f>& world_points, SpatialIndex& map,
                               const std::vector<float>* nearest_dist2 = nullptr,
                               std::vector<Eigen::Vector3f>* inserted = nullptr) = 0;
  virtual std::string name() const = 0;
};

class MappingPolicy final : public MapPolicy {
 public:
  explicit MappingPolicy(const MapPolicyConfig& config) : config_(config) {}
  MapUpdateStats apply(const std::vector<Eigen::Vector3f>& world_points, SpatialIndex& map,
                       const std::vector<float>* nearest_dist2 = nullptr,
                       std::vector<Eigen::Vector3f>* inserted = nullptr) override;
  std::string name() const override { return "mapping"; }

 private:
  MapPolicyConfig config_;
  std::vector<Eigen::Vector3f> to_insert_;
};

class LocalizationPolicy final : public MapPolicy {
 public:
  MapUpdateStats apply(const std::vector<Eigen::Vector3f>& world_points, SpatialIndex&,
                       const std::vector<float>* = nullptr,
                       std::vector<Eigen::Vector3f>* inserted = nullptr) override {
    if (inserted != nullptr) inserted->clear();
    return {world_points.size(), 0};
  }
  std::string name() const override { return "localization"; }
};

std::unique_ptr<MapPolicy> make_map_policy(const MapPolicyConfig& config);

}  // namespace fuse

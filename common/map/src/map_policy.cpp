#include "fuse/map/map_policy.hpp"

#include <cmath>

namespace fuse {

void MapPolicyConfig::load(ConfigNode& node) {
  node.get("mode", mode).get("min_point_distance", min_point_distance);
  node.check(mode == "mapping" || mode == "localization", "mode", "must be mapping or localization");
  node.check(std::isfinite(min_point_distance) && min_point_distance >= 0.0, "min_point_distance", "must be >= 0");
  node.finish();
}

MapUpdateStats MappingPolicy::apply(const std::vector<Eigen::Vector3f>& world_points, SpatialIndex& map,
                                    const std::vector<float>* nearest_dist2,
                                    std::vector<Eigen::Vector3f>* inserted) {
  MapUpdateStats stats;
  stats.offered = world_points.size();
  to_insert_.clear();
  const float min_dist = static_cast<float>(config_.min_point_distance);
  const bool hinted = nearest_dist2 != nullptr && nearest_dist2->size() == world_points.size();
  Neighbors nb;
  for (std::size_t i = 0; i < world_points.size(); ++i) {
    const Eigen::Vector3f& p = world_points[i];
    if (min_dist > 0.f) {
      if (hinted) {
        if ((*nearest_dist2)[i] <= min_dist * min_dist) continue;
      } else {
        map.knn(p, 1, min_dist, nb);
        if (nb.count > 0) continue;
      }
    }
    to_insert_.push_back(p);
  }
  map.insert(to_insert_);
  stats.inserted = to_insert_.size();
  if (inserted != nullptr) *inserted = to_insert_;
  return stats;
}

std::unique_ptr<MapPolicy> make_map_policy(const MapPolicyConfig& config) {
  if (config.mode == "mapping") return std::make_unique<MappingPolicy>(config);
  if (config.mode == "localization") return std::make_unique<LocalizationPolicy>();
  throw ConfigError("map.mode: unknown map policy '" + config.mode + "'");
}

}  // namespace fuse

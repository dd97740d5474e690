// Functional role (DESIGN §1): decides whether accepted observations change the map.
//   mapping:      insert/refine: a point is added unless the map already has a point within
//                 `min_point_distance` of it (keeps density bounded where the map is complete);
//                 with `confirm_s` > 0, a point where the map has nothing yet waits until its
//                 place has been seen for that long (moving objects stay out of the map);
//   localization: the map is fixed; observations only serve association.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "fuse/association/spatial_index.hpp"
#include "fuse/core/config.hpp"

namespace fuse {

struct MapPolicyConfig {
  std::string mode = "mapping";      ///< mapping | localization
  double min_point_distance = 0.25;  ///< m, mapping: skip a point this close to an existing one
  /// s, mapping: a point in space the map does not cover yet is inserted only once its place (a
  /// cube of confirm_cell m) has been observed over at least this long, each sighting within
  /// confirm_forget_s of the previous one; 0 inserts at once. A car or a pedestrian moves out of
  /// a place in well under a second, a wall stays: persistence over time is what tells them apart
  /// without a model of either.
  double confirm_s = 0.0;
  double confirm_cell = 0.5;      ///< m, the size of a place for confirm_s
  double confirm_forget_s = 1.0;  ///< s, a place not seen again for this long starts over
  void load(ConfigNode& node);
};

struct MapUpdateStats {
  std::size_t offered = 0;
  std::size_t inserted = 0;
  std::size_t pending = 0;  ///< new points whose place is not confirmed yet (confirm_s)
};

class MapPolicy {
 public:
  virtual ~MapPolicy() = default;
  /// nearest_dist2 (optional, one per point): squared distance of each point to its nearest map
  /// point, when the association has just measured it; saves searching the map again.
  /// inserted (optional): receives the points the policy inserted into the map (cleared first).
  /// t: when the points were measured (s), for a policy that judges persistence over time.
  virtual MapUpdateStats apply(double t, const std::vector<Eigen::Vector3f>& world_points, SpatialIndex& map,
                               const std::vector<float>* nearest_dist2 = nullptr,
                               std::vector<Eigen::Vector3f>* inserted = nullptr) = 0;
  virtual std::string name() const = 0;
};

class MappingPolicy final : public MapPolicy {
 public:
  explicit MappingPolicy(const MapPolicyConfig& config) : config_(config) {}
  MapUpdateStats apply(double t, const std::vector<Eigen::Vector3f>& world_points, SpatialIndex& map,
                       const std::vector<float>* nearest_dist2 = nullptr,
                       std::vector<Eigen::Vector3f>* inserted = nullptr) override;
  std::string name() const override { return "mapping"; }
  std::size_t places_pending() const { return places_.size(); }

 private:
  /// When a place not yet in the map was seen: first and last of an unbroken run of sightings.
  struct Sighting {
    double first = 0.0, last = 0.0;
  };
  /// Whether the place of p, seen at t, has been seen for confirm_s (and notes the sighting).
  bool confirmed(const Eigen::Vector3f& p, double t);
  void forget_stale(double t);

  MapPolicyConfig config_;
  std::vector<Eigen::Vector3f> to_insert_;
  std::unordered_map<std::uint64_t, Sighting> places_;
  double newest_t_ = -1e300, swept_t_ = -1e300;
  bool seeding_ = false;     ///< the map was empty once: its seed period has been set
  double seed_until_ = -1e300;  ///< until then points go in without confirmation
};

class LocalizationPolicy final : public MapPolicy {
 public:
  MapUpdateStats apply(double, const std::vector<Eigen::Vector3f>& world_points, SpatialIndex&,
                       const std::vector<float>* = nullptr,
                       std::vector<Eigen::Vector3f>* inserted = nullptr) override {
    if (inserted != nullptr) inserted->clear();
    return {world_points.size(), 0, 0};
  }
  std::string name() const override { return "localization"; }
};

std::unique_ptr<MapPolicy> make_map_policy(const MapPolicyConfig& config);

}  // namespace fuse

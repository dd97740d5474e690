// Functional role (DESIGN §1): decides whether accepted observations change the map.
//   mapping:      insert/refine: a point is added unless the map already has a point within
//                 `min_point_distance` of it (keeps density bounded where the map is complete);
//                 with `confirm_s` > 0, a point where the map has nothing yet waits until its
//                 place has been seen for that long (moving objects stay out of the map);
//                 with `carve_s` > 0, a point inserted less than carve_s ago is taken out again
//                 when a later ray passes through it (free-space carving: what a car or a
//                 pedestrian left behind when it moved on); with `carve_lookback_s` > 0, a point
//                 of a new scan where an earlier scan's ray went through is a mover
//                 (mark_moving), left out of the update and the map;
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
#include "fuse/map/free_space_carver.hpp"

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
  /// s, mapping: free-space carving. A point stays on probation this long after it was inserted:
  /// a ray of a later scan that passes within carve_radius of it and ends well beyond it
  /// (carve_beyond, carve_margin) shows the space empty, and the point is removed. 0: off. The
  /// probation bounds the work (only young points are tested) and protects the settled map from
  /// a scan placed wrongly; a moving object leaves its place within a second or two.
  double carve_s = 0.0;
  double carve_radius = 0.25;  ///< m, how close a ray must pass to a point to carve it
  /// The ray must go on beyond the point by at least carve_beyond × the point's range +
  /// carve_margin: it must not carve the surface it ends on just short of its end (a ray
  /// grazing a surface is carve_min_incidence_deg's case). See free_space_carver.hpp.
  double carve_beyond = 0.15;
  double carve_margin = 0.5;  ///< m
  /// Young points tested per scan at most: beyond it each is tested every few scans (in turn),
  /// so that a fast drive through new space cannot make a scan slow.
  std::size_t carve_tests = 20000;
  /// s, a point whose place later scans keep hitting for this long is a surface that stays: it
  /// leaves probation (moving objects do not stay in a place of 2·carve_radius that long).
  double carve_release_s = 0.5;
  /// degrees: a ray meeting the plane of the map around a point at less than this grazes a
  /// surface seen edge-on (a corridor's wall, the ground far ahead) and does not carve it.
  double carve_min_incidence_deg = 15.0;
  /// m: a point on a plane of the map is carved by a ray that crosses that plane within
  /// carve_radius of it and ends at least this far behind the plane (it went through the
  /// surface). Points on no plane keep carve_beyond and carve_margin.
  double carve_plane_gap = 0.3;
  /// s: the points of a scan are tested against the rays of the trusted scans of this long
  /// before; one that a ray passed through (the carving test) lies in space seen empty then: a
  /// mover that came in (mark_moving), left out of the update and the map. 0: off. Needs no
  /// carve_s.
  double carve_lookback_s = 0.0;
  /// Point tests per scan at most for carve_lookback_s: a scan of n points is tested against
  /// carve_lookback_tests / n of the earlier scans (at least one), spread over the lookback.
  std::size_t carve_lookback_tests = 20000;
  void load(ConfigNode& node);
};

struct MapUpdateStats {
  std::size_t offered = 0;
  std::size_t inserted = 0;
  std::size_t pending = 0;  ///< new points whose place is not confirmed yet (confirm_s)
  std::size_t carved = 0;   ///< map points removed because a ray passed through them (carve_s)
};


class MapPolicy {
 public:
  virtual ~MapPolicy() = default;
  /// nearest_dist2 (optional, one per point): squared distance of each point to its nearest map
  /// point, when the association has just measured it; saves searching the map again.
  /// inserted (optional): receives the points the policy inserted into the map (cleared first).
  /// t: when the points were measured (s), for a policy that judges persistence over time.
  /// origins (optional, one per point): where the LiDAR was when it measured each point (world
  /// frame), so that point i ends the ray origins[i] → world_points[i]; only a scan whose pose
  /// is trusted should pass them (they carve the map).
  virtual MapUpdateStats apply(double t, const std::vector<Eigen::Vector3f>& world_points, SpatialIndex& map,
                               const std::vector<float>* nearest_dist2 = nullptr,
                               std::vector<Eigen::Vector3f>* inserted = nullptr,
                               const std::vector<Eigen::Vector3f>* origins = nullptr) = 0;
  virtual std::string name() const = 0;
  /// Whether apply() reads the rays' origins (a policy that carves free space): a caller may
  /// leave them out, and not compute them, when it does not.
  virtual bool uses_rays() const { return false; }
  /// Whether mark_moving() can find anything (a policy that keeps the rays of earlier scans).
  virtual bool marks_moving() const { return false; }
  /// Marks (moving[i] = 1) the points of a scan measured at t, in the world frame, that lie
  /// where an earlier scan saw empty space; returns how many. Only a policy that remembers rays
  /// (carve_lookback_s) marks any.
  virtual std::size_t mark_moving(double /*t*/, const std::vector<Eigen::Vector3f>& world_points,
                                  const SpatialIndex& /*map*/, std::vector<std::uint8_t>& moving) {
    moving.assign(world_points.size(), 0);
    return 0;
  }
};

class MappingPolicy final : public MapPolicy {
 public:
  explicit MappingPolicy(const MapPolicyConfig& config);
  MapUpdateStats apply(double t, const std::vector<Eigen::Vector3f>& world_points, SpatialIndex& map,
                       const std::vector<float>* nearest_dist2 = nullptr,
                       std::vector<Eigen::Vector3f>* inserted = nullptr,
                       const std::vector<Eigen::Vector3f>* origins = nullptr) override;
  std::string name() const override { return "mapping"; }
  bool uses_rays() const override { return config_.carve_s > 0.0 || config_.carve_lookback_s > 0.0; }
  bool marks_moving() const override { return config_.carve_lookback_s > 0.0; }
  std::size_t mark_moving(double t, const std::vector<Eigen::Vector3f>& world_points, const SpatialIndex& map,
                          std::vector<std::uint8_t>& moving) override {
    return carver_.seen_empty(t, world_points, map, moving);
  }
  std::size_t places_pending() const { return places_.size(); }
  std::size_t points_on_probation() const { return carver_.on_probation(); }

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
  FreeSpaceCarver carver_;
};

class LocalizationPolicy final : public MapPolicy {
 public:
  MapUpdateStats apply(double, const std::vector<Eigen::Vector3f>& world_points, SpatialIndex&,
                       const std::vector<float>* = nullptr, std::vector<Eigen::Vector3f>* inserted = nullptr,
                       const std::vector<Eigen::Vector3f>* = nullptr) override {
    if (inserted != nullptr) inserted->clear();
    return {world_points.size(), 0, 0, 0};
  }
  std::string name() const override { return "localization"; }
};

std::unique_ptr<MapPolicy> make_map_policy(const MapPolicyConfig& config);

}  // namespace fuse

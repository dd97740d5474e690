#include "fuse/map/map_policy.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <string>

namespace fuse {

namespace {
constexpr double kMaxConfirmS = 30.0;
/// Each scan kept for carve_lookback_s holds its rays (about 1 MB for 20,000): a bound on memory.
constexpr double kMaxLookbackS = 5.0;
constexpr double kMinConfirmCell = 0.05, kMaxConfirmCell = 10.0;
/// Place keys pack three cell coordinates of this many bits each (±10⁶ cells: ±500 km at 0.5 m).
constexpr int kKeyBits = 21;
constexpr std::int64_t kKeyOffset = std::int64_t{1} << (kKeyBits - 1);
constexpr std::uint64_t kKeyMask = (std::uint64_t{1} << kKeyBits) - 1;
}  // namespace

void MapPolicyConfig::load(ConfigNode& node) {
  node.get("mode", mode).get("min_point_distance", min_point_distance);
  node.get("confirm_s", confirm_s).get("confirm_cell", confirm_cell).get("confirm_forget_s", confirm_forget_s);
  node.check(mode == "mapping" || mode == "localization", "mode", "must be mapping or localization");
  node.check(std::isfinite(min_point_distance) && min_point_distance >= 0.0, "min_point_distance", "must be >= 0");
  node.check(std::isfinite(confirm_s) && confirm_s >= 0.0 && confirm_s <= kMaxConfirmS, "confirm_s",
             "must be in [0, " + std::to_string(static_cast<int>(kMaxConfirmS)) + "] s");
  node.check(std::isfinite(confirm_cell) && confirm_cell >= kMinConfirmCell && confirm_cell <= kMaxConfirmCell,
             "confirm_cell", "must be in [0.05, 10] m");
  node.check(std::isfinite(confirm_forget_s) && confirm_forget_s > 0.0 && confirm_forget_s <= kMaxConfirmS,
             "confirm_forget_s", "must be in (0, " + std::to_string(static_cast<int>(kMaxConfirmS)) + "] s");
  node.get("carve_s", carve_s).get("carve_radius", carve_radius);
  node.get("carve_beyond", carve_beyond).get("carve_margin", carve_margin);
  node.check(std::isfinite(carve_s) && carve_s >= 0.0 && carve_s <= kMaxConfirmS, "carve_s",
             "must be in [0, " + std::to_string(static_cast<int>(kMaxConfirmS)) + "] s");
  node.check(std::isfinite(carve_radius) && carve_radius > 0.0 && carve_radius <= 1.0, "carve_radius",
             "must be in (0, 1] m");
  node.check(std::isfinite(carve_beyond) && carve_beyond >= 0.0 && carve_beyond <= 1.0, "carve_beyond",
             "must be in [0, 1]");
  node.get("carve_tests", carve_tests).get("carve_release_s", carve_release_s);
  node.get("carve_min_incidence_deg", carve_min_incidence_deg).get("carve_plane_gap", carve_plane_gap);
  node.get("carve_lookback_s", carve_lookback_s).get("carve_lookback_tests", carve_lookback_tests);
  node.check(carve_lookback_tests >= 1, "carve_lookback_tests", "must be >= 1");
  node.check(std::isfinite(carve_lookback_s) && carve_lookback_s >= 0.0 && carve_lookback_s <= kMaxLookbackS,
             "carve_lookback_s", "must be in [0, " + std::to_string(static_cast<int>(kMaxLookbackS)) + "] s");
  node.check(std::isfinite(carve_plane_gap) && carve_plane_gap > 0.0 && carve_plane_gap <= 10.0, "carve_plane_gap",
             "must be in (0, 10] m");
  node.check(std::isfinite(carve_min_incidence_deg) && carve_min_incidence_deg >= 0.0 && carve_min_incidence_deg < 90.0,
             "carve_min_incidence_deg", "must be in [0, 90) degrees");
  node.check(std::isfinite(carve_release_s) && carve_release_s > 0.0 && carve_release_s <= kMaxConfirmS,
             "carve_release_s", "must be in (0, " + std::to_string(static_cast<int>(kMaxConfirmS)) + "] s");
  node.check(carve_tests >= 1, "carve_tests", "must be >= 1");
  node.check(std::isfinite(carve_margin) && carve_margin >= 0.0 && carve_margin <= 10.0, "carve_margin",
             "must be in [0, 10] m");
  node.finish();
}

bool MappingPolicy::confirmed(const Eigen::Vector3f& p, double t) {
  const auto cell = [&](float v) {
    const auto c = static_cast<std::int64_t>(std::floor(static_cast<double>(v) / config_.confirm_cell));
    return static_cast<std::uint64_t>(c + kKeyOffset) & kKeyMask;
  };
  const std::uint64_t key = cell(p.x()) | (cell(p.y()) << kKeyBits) | (cell(p.z()) << (2 * kKeyBits));
  auto [it, fresh] = places_.try_emplace(key, Sighting{t, t});
  Sighting& s = it->second;
  if (!fresh) {
    // Observations may come out of order (a map server's resent ones): the run is [first, last].
    if (t > s.last + config_.confirm_forget_s || t < s.first - config_.confirm_forget_s) s = Sighting{t, t};
    s.first = std::min(s.first, t);
    s.last = std::max(s.last, t);
  }
  return s.last - s.first >= config_.confirm_s;
}

void MappingPolicy::forget_stale(double t) {
  // A sweep over the places once per confirm_forget_s: the table holds what a few seconds of
  // scans saw of new space, and a sweep costs far less than a scan.
  if (t < swept_t_ + config_.confirm_forget_s) return;
  swept_t_ = t;
  for (auto it = places_.begin(); it != places_.end();) {
    it = it->second.last < t - config_.confirm_forget_s ? places_.erase(it) : std::next(it);
  }
}

MappingPolicy::MappingPolicy(const MapPolicyConfig& config)
    : config_(config), carver_(CarveConfig{config.carve_s, config.carve_radius, config.carve_beyond, config.carve_margin,
                                           config.carve_min_incidence_deg, config.carve_release_s, config.carve_tests,
                                           config.carve_plane_gap, config.carve_lookback_s,
                                           config.carve_lookback_tests}) {}

MapUpdateStats MappingPolicy::apply(double t, const std::vector<Eigen::Vector3f>& world_points, SpatialIndex& map,
                                    const std::vector<float>* nearest_dist2,
                                    std::vector<Eigen::Vector3f>* inserted,
                                    const std::vector<Eigen::Vector3f>* origins) {
  MapUpdateStats stats;
  stats.offered = world_points.size();
  const bool carving = config_.carve_s > 0.0;
  if ((carving || config_.carve_lookback_s > 0.0) && origins != nullptr && origins->size() == world_points.size()) {
    const std::vector<Eigen::Vector3f>& carved = carver_.carve(t, world_points, *origins, map);
    if (!carved.empty()) stats.carved = map.erase(carved);
  }
  to_insert_.clear();
  const float min_dist = static_cast<float>(config_.min_point_distance);
  const bool hinted = nearest_dist2 != nullptr && nearest_dist2->size() == world_points.size();
  // The first confirm_s of points into an empty map seed it as they are: a single scan is too
  // sparse to track against, and a place can only be confirmed after confirm_s anyway (a sensor
  // starts at rest; what moved through the scene in that time is mapped).
  if (map.size() == 0 && !seeding_) {
    seeding_ = true;
    seed_until_ = t + config_.confirm_s;
  }
  const bool confirm = config_.confirm_s > 0.0 && t > seed_until_;
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
    if (confirm && !confirmed(p, t)) {
      ++stats.pending;
      continue;
    }
    to_insert_.push_back(p);
  }
  if (confirm) {
    newest_t_ = std::max(newest_t_, t);
    forget_stale(newest_t_);
  }
  map.insert(to_insert_);
  stats.inserted = to_insert_.size();
  if (carving) carver_.add(t, to_insert_);
  if (inserted != nullptr) *inserted = to_insert_;
  return stats;
}

std::unique_ptr<MapPolicy> make_map_policy(const MapPolicyConfig& config) {
  if (config.mode == "mapping") return std::make_unique<MappingPolicy>(config);
  if (config.mode == "localization") return std::make_unique<LocalizationPolicy>();
  throw ConfigError("map.mode: unknown map policy '" + config.mode + "'");
}

}  // namespace fuse

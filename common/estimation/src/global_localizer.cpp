#include "fuse/estimation/global_localizer.hpp"

#include "fuse/association/associator.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_set>

namespace fuse {

void GlobalLocalizationConfig::load(ConfigNode& node) {
  node.get("enabled", enabled).get("resolution", resolution).get("levels", levels).get("submap_radius", submap_radius);
  node.get("max_points", max_points).get("min_travel", min_travel).get("min_time", min_time).get("period", period).get("min_score", min_score);
  node.get("candidate_margin", candidate_margin).get("max_candidates", max_candidates).get("fit_residual", fit_residual);
  node.get("window_prior_d2", window_prior_d2);
  node.get("min_fit", min_fit).get("window_inner", window_inner).get("ambiguity_ratio", ambiguity_ratio).get("ambiguity_margin", ambiguity_margin).get("distinct_distance", distinct_distance);
  node.get("agreeing_searches", agreeing_searches).get("max_map_tilt", max_map_tilt);
  node.check(std::isfinite(max_map_tilt) && max_map_tilt > 0.0 && max_map_tilt <= 0.5, "max_map_tilt", "must be in (0, 0.5] rad");
  node.check(agreeing_searches >= 1 && agreeing_searches <= 10, "agreeing_searches", "must be in [1, 10]");
  node.get("distinct_angle", distinct_angle).get("map_margin", map_margin).get("max_cells", max_cells);
  node.get("max_nodes", max_nodes);
  node.get("confirm_s", confirm_s).get("blocking", blocking).get("lost_search_after_s", lost_search_after_s);
  node.check(std::isfinite(resolution) && resolution >= 0.05 && resolution <= 5.0, "resolution", "must be in [0.05, 5] m");
  node.check(levels >= 0 && levels <= 10, "levels", "must be in [0, 10]");
  node.check(std::isfinite(submap_radius) && submap_radius > resolution && submap_radius <= 500.0, "submap_radius",
             "must be above the resolution and at most 500 m");
  node.check(max_points >= 50 && max_points <= 1000000, "max_points", "must be in [50, 1000000]");
  node.check(std::isfinite(min_travel) && min_travel >= 0.0, "min_travel", "must be finite and >= 0 m");
  node.check(std::isfinite(min_time) && min_time >= 0.0, "min_time", "must be finite and >= 0 s");
  node.check(std::isfinite(period) && period > 0.0, "period", "must be finite and > 0 s");
  node.check(std::isfinite(min_score) && min_score > 0.0 && min_score <= 1.0, "min_score", "must be in (0, 1]");
  node.check(std::isfinite(candidate_margin) && candidate_margin >= 0.0 && candidate_margin < 1.0, "candidate_margin",
             "must be in [0, 1)");
  node.check(max_candidates >= 1 && max_candidates <= 256, "max_candidates", "must be in [1, 256]");
  node.check(std::isfinite(fit_residual) && fit_residual > 0.0 && fit_residual <= 2.0, "fit_residual", "must be in (0, 2] m");
  node.check(std::isfinite(min_fit) && min_fit > 0.0 && min_fit <= 1.0, "min_fit", "must be in (0, 1]");
  node.check(std::isfinite(window_inner) && window_inner > 0.0 && window_inner <= 1.0, "window_inner", "must be in (0, 1]");
  node.check(std::isfinite(window_prior_d2) && window_prior_d2 >= 0.0, "window_prior_d2", "must be >= 0");
  node.check(std::isfinite(ambiguity_ratio) && ambiguity_ratio >= 1.0 && ambiguity_ratio <= 100.0, "ambiguity_ratio",
             "must be in [1, 100]");
  node.check(std::isfinite(ambiguity_margin) && ambiguity_margin >= 0.0 && ambiguity_margin < 1.0, "ambiguity_margin",
             "must be in [0, 1)");
  node.check(std::isfinite(distinct_distance) && distinct_distance > 0.0, "distinct_distance", "must be finite and > 0 m");
  node.check(std::isfinite(distinct_angle) && distinct_angle > 0.0 && distinct_angle <= M_PI, "distinct_angle",
             "must be in (0, pi] rad");
  node.check(std::isfinite(map_margin) && map_margin >= 0.0 && map_margin <= 100.0, "map_margin", "must be in [0, 100] m");
  node.check(std::isfinite(max_cells) && max_cells >= 1e3 && max_cells <= 1e9, "max_cells", "must be in [1e3, 1e9]");
  node.check(std::isfinite(max_nodes) && max_nodes >= 1e3 && max_nodes <= 1e10, "max_nodes", "must be in [1e3, 1e10]");
  node.check(std::isfinite(confirm_s) && confirm_s >= 0.0 && confirm_s <= 60.0, "confirm_s", "must be in [0, 60] s");
  node.check(std::isfinite(lost_search_after_s) && lost_search_after_s >= 0.0 && lost_search_after_s <= 3600.0,
             "lost_search_after_s", "must be in [0, 3600] s");
  node.finish();
}

const char* to_string(GlobalSearchResult::Verdict v) {
  switch (v) {
    case GlobalSearchResult::Verdict::kLocalized:
      return "localized";
    case GlobalSearchResult::Verdict::kAmbiguous:
      return "ambiguous";
    case GlobalSearchResult::Verdict::kNotFound:
      return "not found";
  }
  return "?";
}

std::string GlobalSearchResult::describe() const {
  std::string s = fmt::format("{}: best ({:.2f}, {:.2f}, {:.2f}) m, heading {:+.1f} deg, fit {:.3f} (grid {:.3f})",
                              to_string(verdict), best.position.x(), best.position.y(), best.position.z(),
                              best.yaw * 180.0 / M_PI, best.fit, best.score);
  if (rival) {
    s += fmt::format("; rival ({:.2f}, {:.2f}, {:.2f}) m, heading {:+.1f} deg, fit {:.3f} (grid {:.3f})", rival->position.x(),
                     rival->position.y(), rival->position.z(), rival->yaw * 180.0 / M_PI, rival->fit, rival->score);
  }
  return s + fmt::format("; {} candidate(s), {} points, {} nodes{}, {:.0f} ms", candidates, points, nodes,
                         exhausted ? " (max_nodes reached: not searched to the end)" : "", ms);
}

GlobalLocalizer::GlobalLocalizer(const GlobalLocalizationConfig& config, const std::vector<Eigen::Vector3f>& map_points)
    : config_(config) {
  if (map_points.empty()) throw std::invalid_argument("global localization: the map is empty");
  Eigen::Vector3d lo = map_points.front().cast<double>(), hi = lo;
  for (const Eigen::Vector3f& p : map_points) {
    lo = lo.cwiseMin(p.cast<double>());
    hi = hi.cwiseMax(p.cast<double>());
  }
  // The finest resolution whose grid fits in max_cells: a large map is searched coarser (the
  // refinement restores the precision), never refused for its size alone.
  double r = config_.resolution;
  origin_ = lo - Eigen::Vector3d::Constant(config_.map_margin);
  const Eigen::Vector3d extent = hi - lo + Eigen::Vector3d::Constant(2.0 * config_.map_margin);
  Eigen::Vector3d cells = (extent / r).array().ceil() + 1.0;
  constexpr double kCoarsest = 4.0;  // m: beyond this a grid no longer tells places apart
  while (cells.prod() > config_.max_cells && 2.0 * r <= kCoarsest) {
    r *= 2.0;
    cells = (extent / r).array().ceil() + 1.0;
  }
  if (cells.prod() > config_.max_cells) {
    throw std::invalid_argument(fmt::format("global localization: the map's bounding box ({:.0f} x {:.0f} x {:.0f} m) needs "
                                            "{:.3g} cells even at resolution {} m, more than global_localization.max_cells {:.3g}",
                                            extent.x(), extent.y(), extent.z(), cells.prod(), r, config_.max_cells));
  }
  config_.resolution = r;
  size_ = cells.cast<int>();
  SpatialIndexConfig index_config;
  index_config.type = "kdtree";  // a fixed map: no LRU, no voxel capacity
  std::shared_ptr<SpatialIndex> map_index = make_spatial_index(index_config);
  map_index->insert(map_points);
  index_ = std::move(map_index);
  const std::size_t n = static_cast<std::size_t>(size_.x()) * size_.y() * size_.z();
  auto index = [&](int x, int y, int z) { return (static_cast<std::size_t>(z) * size_.y() + y) * size_.x() + x; };

  // G₀: 2 within one cell (Chebyshev distance) of a cell holding a map point, 1 within two. The
  // tolerance absorbs the lattice: the true translation lies up to half a cell from the nearest
  // one searched.
  std::vector<std::uint8_t> occupied(n, 0);
  for (const Eigen::Vector3f& p : map_points) {
    const Eigen::Vector3i c = ((p.cast<double>() - origin_) / r).array().floor().cast<int>();
    occupied[index(c.x(), c.y(), c.z())] = 1;
  }
  // Dilation by k cells: a running maximum over [c − k, c + k] along x, then y, then z.
  auto dilate = [&](std::vector<std::uint8_t> a, int k) {
    std::vector<std::uint8_t> b(n, 0);
    for (int axis = 0; axis < 3; ++axis) {
      for (int z = 0; z < size_.z(); ++z)
        for (int y = 0; y < size_.y(); ++y)
          for (int x = 0; x < size_.x(); ++x) {
            std::uint8_t v = 0;
            Eigen::Vector3i c(x, y, z);
            const int centre = c(axis);
            for (int d = -k; d <= k && v == 0; ++d) {
              c(axis) = centre + d;
              if (c(axis) >= 0 && c(axis) < size_(axis)) v = a[index(c.x(), c.y(), c.z())];
            }
            b[index(x, y, z)] = v;
          }
      std::swap(a, b);
    }
    return a;
  };
  const std::vector<std::uint8_t> within1 = dilate(occupied, 1), within2 = dilate(occupied, 2);
  std::vector<std::uint8_t> g0(n, 0);
  for (std::size_t i = 0; i < n; ++i) g0[i] = within1[i] ? 2 : (within2[i] ? 1 : 0);
  grids_.push_back(std::move(g0));

  // G_k(c) = max(G_{k-1}(c), G_{k-1}(c + h e)) along x, then y, then z, with h = 2^(k-1): the
  // maximum over the cube [c, c + 2^k)³.
  for (int k = 1; k <= config_.levels; ++k) {
    const int h = 1 << (k - 1);
    std::vector<std::uint8_t> a = grids_.back(), b(n, 0);
    for (int axis = 0; axis < 3; ++axis) {
      for (int z = 0; z < size_.z(); ++z)
        for (int y = 0; y < size_.y(); ++y)
          for (int x = 0; x < size_.x(); ++x) {
            Eigen::Vector3i c(x, y, z);
            std::uint8_t v = a[index(x, y, z)];
            c(axis) += h;
            if (c(axis) < size_(axis)) v = std::max(v, a[index(c.x(), c.y(), c.z())]);
            b[index(x, y, z)] = v;
          }
      std::swap(a, b);
    }
    grids_.push_back(std::move(a));
  }
}

namespace {
using Clock = std::chrono::steady_clock;

/// The submap points that are scored: within the radius, one per grid cell, evenly thinned to at
/// most max_points.
std::vector<Eigen::Vector3f> thin(const std::vector<Eigen::Vector3f>& submap, const GlobalLocalizationConfig& c) {
  const float r2 = static_cast<float>(c.submap_radius * c.submap_radius);
  const float inv = static_cast<float>(1.0 / c.resolution);
  std::unordered_set<std::uint64_t> seen;
  std::vector<Eigen::Vector3f> kept;
  for (const Eigen::Vector3f& q : submap) {
    if (!q.allFinite() || q.squaredNorm() > r2) continue;
    if (seen.insert(cell_key(q, inv)).second) kept.push_back(q);
  }
  const auto max_points = static_cast<std::size_t>(c.max_points);
  if (kept.size() <= max_points) return kept;
  std::vector<Eigen::Vector3f> out;
  out.reserve(max_points);
  for (std::size_t i = 0; i < max_points; ++i) out.push_back(kept[i * kept.size() / max_points]);
  return out;
}

double wrap(double a) { return std::remainder(a, 2.0 * M_PI); }
}  // namespace

struct GlobalLocalizer::Search {
  const GlobalLocalizer& g;
  std::vector<double> yaws;
  std::vector<std::vector<Eigen::Vector3i>> offsets;  ///< per yaw: ⌊Rz(ψ) q_n / r⌋
  Eigen::Vector3i lo, hi;                            ///< translation cells searched, inclusive
  std::size_t nodes = 0;
  std::size_t budget = 0;  ///< max_nodes: past it nothing more is expanded
  bool exhausted() const { return nodes >= budget; }

  struct Node {
    int bound;
    int yaw;
    Eigen::Vector3i t;
    int level;
  };

  int bound(int yaw, const Eigen::Vector3i& t, int level) {
    ++nodes;
    int s = 0;
    for (const Eigen::Vector3i& o : offsets[yaw]) s += g.at(level, o + t);
    return s;
  }
  Eigen::Vector3d position(const Eigen::Vector3i& t) const { return g.origin_ + g.config_.resolution * t.cast<double>(); }
  GlobalPose pose(const Node& n, double points) const { return {position(n.t), yaws[n.yaw], n.bound / (2.0 * points)}; }

  std::vector<Node> roots() {
    const int step = 1 << g.config_.levels;
    std::vector<Node> out;
    for (int y = 0; y < static_cast<int>(yaws.size()); ++y)
      for (int tz = lo.z(); tz <= hi.z(); tz += step)
        for (int ty = lo.y(); ty <= hi.y(); ty += step)
          for (int tx = lo.x(); tx <= hi.x(); tx += step) {
            const Eigen::Vector3i t(tx, ty, tz);
            out.push_back({bound(y, t, g.config_.levels), y, t, g.config_.levels});
          }
    std::sort(out.begin(), out.end(), [](const Node& a, const Node& b) { return a.bound > b.bound; });
    return out;
  }

  /// Depth first below `n`, children in order of their bounds; `visit` is called on every leaf
  /// whose score reaches `need()`, and a node whose bound is below it is not expanded. `skip`
  /// discards whole nodes.
  template <class Need, class Visit, class Skip>
  void descend(const Node& n, Need&& need, Visit&& visit, Skip&& skip) {
    if (exhausted() || n.bound < need() || skip(n)) return;
    if (n.level == 0) {
      visit(n);
      return;
    }
    const int h = 1 << (n.level - 1);
    std::array<Node, 8> children;
    int m = 0;
    for (int d = 0; d < 8; ++d) {
      const Eigen::Vector3i t = n.t + h * Eigen::Vector3i(d & 1, (d >> 1) & 1, (d >> 2) & 1);
      if ((t.array() > hi.array()).any()) continue;
      children[m++] = {bound(n.yaw, t, n.level - 1), n.yaw, t, n.level - 1};
    }
    for (int i = 1; i < m; ++i) {  // insertion sort by bound, highest first (at most 8)
      for (int j = i; j > 0 && children[j].bound > children[j - 1].bound; --j) std::swap(children[j], children[j - 1]);
    }
    for (int i = 0; i < m; ++i) descend(children[i], need, visit, skip);
  }
};

double GlobalLocalizer::score(const std::vector<Eigen::Vector3f>& submap_in, const Eigen::Vector3d& position, double yaw) const {
  const std::vector<Eigen::Vector3f> submap = thin(submap_in, config_);
  if (submap.empty()) return 0.0;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  int s = 0;
  for (const Eigen::Vector3f& q : submap) {
    const Eigen::Vector3d p = R * q.cast<double>() + position;
    s += at(0, ((p - origin_) / config_.resolution).array().floor().cast<int>());
  }
  return s / (2.0 * static_cast<double>(submap.size()));
}

GlobalPose GlobalLocalizer::refine(const std::vector<Eigen::Vector3f>& submap, const GlobalPose& start) const {
  constexpr int kIterations = 12;
  constexpr double kStartTrim = 1.0, kTrimShrink = 0.7;  // m: residuals beyond max(τ, 1.0·0.7^k) are left out
  AssociationConfig ac;
  ac.screening = false;
  ac.max_neighbor_distance = 1.0;
  const Associator associator(ac);
  GlobalPose x = start;
  ConstraintSet set;
  const Eigen::Vector3d ez = Eigen::Vector3d::UnitZ();
  auto transform = [](const GlobalPose& p) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::AngleAxisd(p.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T.translation() = p.position;
    return T;
  };
  for (int k = 0; k < kIterations; ++k) {
    const Eigen::Isometry3d T = transform(x);
    associator.associate(submap, T, *index_, set);
    const double trim = std::max(config_.fit_residual, kStartTrim * std::pow(kTrimShrink, k));
    Eigen::Matrix4d H = Eigen::Matrix4d::Zero();
    Eigen::Vector4d b = Eigen::Vector4d::Zero();
    for (const Constraint& c : set.constraints) {
      const Eigen::Vector3d n = c.normal.cast<double>();
      const Eigen::Vector3d Rq = T.linear() * c.point.cast<double>();
      const double r = n.dot(Rq + T.translation()) + c.d;
      if (std::abs(r) > trim) continue;
      Eigen::Vector4d J;
      J << n, n.dot(ez.cross(Rq));
      H += J * J.transpose();
      b += J * r;
    }
    if (H.trace() <= 0.0) break;
    H.diagonal().array() += 1e-6 * H.trace();  // a corridor leaves a direction unconstrained
    const Eigen::Vector4d delta = -H.ldlt().solve(b);
    if (!delta.allFinite()) break;
    x.position += delta.head<3>();
    x.yaw = std::remainder(x.yaw + delta(3), 2.0 * M_PI);
    if (delta.head<3>().norm() < 1e-3 && std::abs(delta(3)) < 1e-4) break;
  }
  // fit = (1/N) Σ_n max(0, 1 − r_n²/τ²) at the refined pose, a point without a plane scoring 0.
  const Eigen::Isometry3d T = transform(x);
  associator.associate(submap, T, *index_, set);
  const double tau = config_.fit_residual;
  double sum = 0.0;
  for (const Constraint& c : set.constraints) {
    const double r = c.normal.cast<double>().dot(T * c.point.cast<double>()) + c.d;
    sum += std::max(0.0, 1.0 - r * r / (tau * tau));
  }
  x.fit = submap.empty() ? 0.0 : sum / static_cast<double>(submap.size());
  return x;
}

GlobalSearchResult GlobalLocalizer::search(const std::vector<Eigen::Vector3f>& submap,
                                           const std::optional<SearchWindow>& window) const {
  const auto t0 = Clock::now();
  GlobalSearchResult result;
  const std::vector<Eigen::Vector3f> points = thin(submap, config_);
  result.points = points.size();
  if (points.empty()) return result;
  const double r = config_.resolution;
  const double n = static_cast<double>(points.size());

  Search s{*this, {}, {}, Eigen::Vector3i::Zero(), size_ - Eigen::Vector3i::Ones(), 0,
           static_cast<std::size_t>(config_.max_nodes)};
  // Heading step: the farthest point (horizontally) moves by at most two cells between steps, at
  // most one from the nearest step.
  double reach = r;
  for (const Eigen::Vector3f& q : points) reach = std::max(reach, static_cast<double>(q.head<2>().norm()));
  const double step = 2.0 * r / reach;  // G₀'s one-cell tolerance
  if (window) {
    const Eigen::Vector3d half(window->radius_xy, window->radius_xy, window->radius_z);
    s.lo = ((window->center - half - origin_) / r).array().floor().cast<int>().max(0);
    s.hi = ((window->center + half - origin_) / r).array().ceil().cast<int>().min((size_ - Eigen::Vector3i::Ones()).array());
    const int k = static_cast<int>(std::ceil(window->yaw_range / step));
    for (int i = -k; i <= k; ++i) s.yaws.push_back(wrap(window->yaw + i * step));
  } else {
    const int k = static_cast<int>(std::ceil(2.0 * M_PI / step));
    for (int i = 0; i < k; ++i) s.yaws.push_back(wrap(2.0 * M_PI * i / k));
  }
  if ((s.lo.array() > s.hi.array()).any()) {
    result.ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    return result;  // the window lies outside the map
  }
  for (double yaw : s.yaws) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    std::vector<Eigen::Vector3i> o;
    o.reserve(points.size());
    for (const Eigen::Vector3f& q : points) o.push_back(((R * q.cast<double>()) / r).array().floor().cast<int>());
    s.offsets.push_back(std::move(o));
  }
  const std::vector<Search::Node> roots = s.roots();
  const int required = static_cast<int>(std::ceil(config_.min_score * 2.0 * n));

  // Pass 1: the best pose (a strictly better leaf replaces it).
  std::optional<Search::Node> best;
  auto need_best = [&] { return best ? best->bound + 1 : required; };
  auto keep_best = [&](const Search::Node& leaf) { best = leaf; };
  auto none = [](const Search::Node&) { return false; };
  for (const Search::Node& root : roots) s.descend(root, need_best, keep_best, none);
  if (!best) {
    // Nothing reaches min_score: report the best leaf below it, for the log.
    std::optional<Search::Node> top;
    auto need_top = [&] { return top ? top->bound + 1 : 0; };
    for (const Search::Node& root : roots) s.descend(root, need_top, [&](const Search::Node& l) { top = l; }, none);
    if (top) result.best = s.pose(*top, n);
    result.nodes = s.nodes;
    result.exhausted = s.exhausted();
    result.ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    return result;
  }
  result.best = s.pose(*best, n);
  result.best_grid_score = result.best.score;

  // Further passes: the best pose outside the neighbourhoods of those found so far (a node wholly
  // inside one is not expanded), while it scores within candidate_margin of the best: the
  // candidates are the regional maxima, best scoring first.
  const int margin = static_cast<int>(std::floor(config_.candidate_margin * 2.0 * n));
  const int floor_score = std::max(required, best->bound - margin);
  std::vector<GlobalPose> candidates = {result.best};
  auto distinct = [&](const GlobalPose& a, const GlobalPose& b) {
    return (a.position - b.position).norm() > config_.distinct_distance || std::abs(wrap(a.yaw - b.yaw)) > config_.distinct_angle;
  };
  auto inside_found = [&](const Search::Node& node) {
    // The node's translations span [t, t + 2^level) cells: inside a neighbourhood when its
    // farthest corner is.
    const Eigen::Vector3d a = s.position(node.t);
    const Eigen::Vector3d b = a + Eigen::Vector3d::Constant(r * ((1 << node.level) - 1));
    for (const GlobalPose& c : candidates) {
      if (std::abs(wrap(s.yaws[node.yaw] - c.yaw)) > config_.distinct_angle) continue;
      const Eigen::Vector3d far = (a - c.position).cwiseAbs().cwiseMax((b - c.position).cwiseAbs());
      if (far.norm() <= config_.distinct_distance) return true;
    }
    return false;
  };
  while (candidates.size() < static_cast<std::size_t>(config_.max_candidates)) {
    std::optional<Search::Node> next;
    auto need_next = [&] { return next ? next->bound + 1 : floor_score; };
    auto keep_next = [&](const Search::Node& leaf) {
      if (std::all_of(candidates.begin(), candidates.end(), [&](const GlobalPose& c) { return distinct(c, s.pose(leaf, n)); })) {
        next = leaf;
      }
    };
    for (const Search::Node& root : roots) s.descend(root, need_next, keep_next, inside_found);
    if (!next) break;
    candidates.push_back(s.pose(*next, n));
  }
  // Refine each; the best fit must stand out (refining can bring two candidates together: they
  // then count once).
  for (GlobalPose& c : candidates) c = refine(points, c);
  std::sort(candidates.begin(), candidates.end(), [](const GlobalPose& a, const GlobalPose& b) { return a.fit > b.fit; });
  result.best = candidates.front();
  // The given pose's prior (Mahalanobis distance², horizontal position and heading).
  auto prior_d2 = [&](const GlobalPose& c) {
    if (!window || window->sigma_xy <= 0.0 || window->sigma_yaw <= 0.0) return 0.0;
    const double dp = (c.position.head<2>() - window->center.head<2>()).norm() / window->sigma_xy;
    const double dy = wrap(c.yaw - window->yaw) / window->sigma_yaw;
    return dp * dp + dy * dy;
  };
  auto rivals_best = [&](const GlobalPose& c) {
    if (prior_d2(c) - prior_d2(result.best) > config_.window_prior_d2) return false;  // the prior rules it out
    return (1.0 - c.fit) < config_.ambiguity_ratio * (1.0 - result.best.fit) ||
           c.fit > result.best.fit - config_.ambiguity_margin;
  };
  result.candidates = 1;
  for (std::size_t i = 1; i < candidates.size(); ++i) {
    const GlobalPose& c = candidates[i];
    if (!distinct(c, result.best)) continue;  // refined into the same place
    if (!result.rival) result.rival = c;     // the runner-up, for the log
    if (rivals_best(c)) ++result.candidates;
  }
  auto inside_window = [&](const GlobalPose& p) {
    if (!window) return true;
    const double k = config_.window_inner;
    return (p.position.head<2>() - window->center.head<2>()).norm() <= k * window->radius_xy &&
           std::abs(p.position.z() - window->center.z()) <= k * window->radius_z + r &&
           std::abs(wrap(p.yaw - window->yaw)) <= k * window->yaw_range;
  };
  if (result.best.fit < config_.min_fit || !inside_window(result.best)) {
    result.verdict = GlobalSearchResult::Verdict::kNotFound;
  } else {
    result.verdict = result.candidates > 1 ? GlobalSearchResult::Verdict::kAmbiguous : GlobalSearchResult::Verdict::kLocalized;
  }
  result.nodes = s.nodes;
  if (s.exhausted()) {  // not searched to the end: a better place may lie in what was left
    result.exhausted = true;
    result.verdict = GlobalSearchResult::Verdict::kNotFound;
  }
  result.ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  return result;
}

}  // namespace fuse

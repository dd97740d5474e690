#include "fuse/estimation/map_localization.hpp"

#include <cmath>

#include "fuse/core/logging.hpp"

namespace fuse {

const char* to_string(MapLocalization::State s) {
  switch (s) {
    case MapLocalization::State::kSearching:
      return "searching";
    case MapLocalization::State::kConfirming:
      return "confirming";
    case MapLocalization::State::kLocalized:
      return "localized";
  }
  return "?";
}

Eigen::Matrix3d levelling(const Eigen::Vector3d& g) {
  return Eigen::Quaterniond::FromTwoVectors(g.normalized(), -Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

namespace {
std::vector<Eigen::Vector3f> rotated(const std::vector<Eigen::Vector3f>& points, const Eigen::Matrix3d& R) {
  const Eigen::Matrix3f Rf = R.cast<float>();
  std::vector<Eigen::Vector3f> out;
  out.reserve(points.size());
  for (const Eigen::Vector3f& p : points) out.push_back(Rf * p);
  return out;
}
}  // namespace

MapLocalization::MapLocalization(const GlobalLocalizationConfig& config, std::vector<Eigen::Vector3f> map_points,
                                 std::optional<InitialPose> initial_pose, const Eigen::Vector3d& map_gravity)
    : config_(config),
      map_points_(std::move(map_points)),
      level_M_(levelling(map_gravity)),
      localizer_(std::make_shared<const GlobalLocalizer>(config, rotated(map_points_, level_M_))),
      initial_pose_(initial_pose) {
  const Eigen::Vector3i n = localizer_->grid_size();
  logger("estimator")->info("global localization: {} map points, search grid {} x {} x {} cells of {} m", map_points_.size(), n.x(),
                            n.y(), n.z(), resolution());
}

MapLocalization::~MapLocalization() {
  if (pending_ && pending_->result.valid()) pending_->result.wait();  // the search holds no reference to this
}

std::vector<Eigen::Vector3f> MapLocalization::session_points() const {
  std::vector<Eigen::Vector3f> out;
  out.reserve(submap_.size());
  for (const auto& [key, p] : submap_) out.push_back(p);
  return out;
}

std::string MapLocalization::describe() const {
  if (state_ != State::kSearching || !last_) return to_string(state_);
  return fmt::format("searching ({}: {} candidate(s))", to_string(last_->verdict), last_->candidates);
}

std::optional<SearchWindow> MapLocalization::window_for(const Eigen::Vector3d& sensor_S) const {
  if (!initial_pose_ || initial_pose_refused_) return std::nullopt;
  // The initial pose is the IMU's at the session start, i.e. T_M_S itself.
  const InitialPose& h = *initial_pose_;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(h.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = h.position;
  SearchWindow w;
  w.center = level_M_ * (T * sensor_S);  // in the levelled map
  w.radius_xy = 3.0 * h.std_xy + resolution();
  w.radius_z = 3.0 * h.std_z + resolution();
  w.yaw = h.yaw;
  w.yaw_range = std::min(M_PI, 3.0 * h.std_yaw);
  w.sigma_xy = h.std_xy;
  w.sigma_yaw = h.std_yaw;
  return w;
}

std::optional<Eigen::Isometry3d> MapLocalization::on_scan(double t, const std::vector<Eigen::Vector3f>& points_S,
                                                          const Eigen::Vector3d& sensor_S, const Eigen::Vector3d& gravity_S) {
  if (state_ != State::kSearching) return std::nullopt;
  if (!t_first_) t_first_ = t;
  const float inv = static_cast<float>(2.0 / config_.resolution);  // half-cell voxels
  for (const Eigen::Vector3f& p : points_S) {
    if (!p.allFinite()) continue;
    submap_.try_emplace(cell_key(p, inv), p);
  }
  if (pending_) {
    const bool ready = config_.blocking ||
                       pending_->result.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
    if (!ready) return std::nullopt;
    Pending p = std::move(*pending_);
    pending_.reset();
    if (auto T = finish(take(p), p, t)) return T;
  }
  // Due: the first search of the whole map once min_time of data is gathered (around an initial
  // pose at once); later ones when the sensor moved min_travel (a new view) or period passed.
  const std::optional<SearchWindow> window = window_for(sensor_S);
  if (!last_search_at_) {
    if (!window && t - *t_first_ < config_.min_time) return std::nullopt;
  } else if ((sensor_S - *last_search_at_).norm() < config_.min_travel && t - last_search_t_ < config_.period) {
    return std::nullopt;
  }
  last_search_at_ = sensor_S;
  last_search_t_ = t;
  // Relative to the sensor, levelled by the session's gravity estimate.
  const Eigen::Matrix3d level_S = levelling(gravity_S);
  const Eigen::Matrix3f level_Sf = level_S.cast<float>();
  std::vector<Eigen::Vector3f> relative;
  relative.reserve(submap_.size());
  const Eigen::Vector3f c = sensor_S.cast<float>();
  const auto r2 = static_cast<float>(config_.submap_radius * config_.submap_radius);
  for (const auto& [key, p] : submap_) {
    if ((p - c).squaredNorm() <= r2) relative.push_back(level_Sf * (p - c));
  }
  std::shared_ptr<const GlobalLocalizer> localizer = localizer_;
  Pending p;
  p.sensor_S = sensor_S;
  p.level_S = level_S;
  p.windowed = window.has_value();
  p.result = std::async(config_.blocking ? std::launch::deferred : std::launch::async,
                        [localizer, relative = std::move(relative), window] { return localizer->search(relative, window); });
  pending_ = std::move(p);
  if (config_.blocking) {
    Pending q = std::move(*pending_);
    pending_.reset();
    return finish(take(q), q, t);
  }
  return std::nullopt;
}

GlobalSearchResult MapLocalization::take(Pending& p) {
  // A search that threw (out of memory, say) is a search that found nothing: logged, and the
  // next one is due as usual; it never takes the estimator down with it.
  try {
    return p.result.get();
  } catch (const std::exception& e) {
    logger("estimator")->error("global localization search failed: {}", e.what());
    return GlobalSearchResult{};
  }
}

std::optional<Eigen::Isometry3d> MapLocalization::finish(GlobalSearchResult r, const Pending& p, double t) {
  ++searches_;
  search_ms_ += r.ms;
  auto log = logger("estimator");
  log->info("global localization at t={:.3f} ({:.1f} s of data, {} submap points{}): {}", t, t - *t_first_, submap_.size(),
            p.windowed ? ", around the initial pose" : "", r.describe());
  last_ = r;
  if (p.windowed && r.verdict == GlobalSearchResult::Verdict::kNotFound) {
    initial_pose_refused_ = true;
    log->warn("initial pose refused: no pose within its window fits the map (best fit {:.3f}, needs "
              "global_localization.min_fit {:.2f}, within {:.0f}% of the window); searching the whole map",
              r.best.fit, config_.min_fit, 100.0 * config_.window_inner);
    last_search_at_.reset();  // search the whole map at once
    return std::nullopt;
  }
  if (r.verdict != GlobalSearchResult::Verdict::kLocalized) {
    agreeing_ = 0;
    return std::nullopt;
  }
  // A session point p lies at Rz(ψ) L_S (p − c) + t in the levelled map M', and M = L_Mᵀ M':
  //   T_M_S = [L_Mᵀ Rz(ψ) L_S | L_Mᵀ (t − Rz(ψ) L_S c)].
  const Eigen::Matrix3d R_prime = Eigen::AngleAxisd(r.best.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * p.level_S;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = level_M_.transpose() * R_prime;
  T.translation() = level_M_.transpose() * (r.best.position - R_prime * p.sensor_S);
  if (p.windowed) return T;  // confined around a given pose: one search decides
  // Searches of the whole map must agree: the same T_M_S (the session's odometry between them is
  // good over a few metres) from agreeing_searches places in a row.
  const bool agrees = agreed_ && (agreed_->translation() - T.translation()).norm() <= config_.distinct_distance &&
                      Eigen::AngleAxisd(agreed_->linear().transpose() * T.linear()).angle() <= config_.distinct_angle;
  agreeing_ = agrees ? agreeing_ + 1 : 1;
  agreed_ = T;
  if (agreeing_ < config_.agreeing_searches) {
    log->info("global localization: {} of {} searches in a row agree on this location; searching again as the sensor moves",
              agreeing_, config_.agreeing_searches);
    return std::nullopt;
  }
  agreeing_ = 0;
  return T;
}

void MapLocalization::taken(double t) {
  state_ = State::kConfirming;
  confirm_until_ = t + config_.confirm_s;
}

void MapLocalization::confirmed(double t) {
  state_ = State::kLocalized;
  logger("estimator")->info("global localization confirmed at t={:.3f}: the scans fit the map", t);
  submap_.clear();
}

void MapLocalization::dropped(double t, const std::string& why) {
  state_ = State::kSearching;
  logger("estimator")->warn("global localization dropped at t={:.3f}: {}; searching again", t, why);
}

}  // namespace fuse

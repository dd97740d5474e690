#include "map_service.hpp"

#include <cmath>
#include <filesystem>
#include <future>
#include <map>
#include <stdexcept>
#include <vector>

#include "fuse/core/logging.hpp"
#include "fuse/map/map_names.hpp"

namespace fuse::map_service {

namespace {

std::shared_ptr<spdlog::logger> log() { return logger("fuse-map"); }

/// Longest text of a string<256> field (the bound of fuse_msgs' error strings, less the NUL).
constexpr std::size_t kMaxErrorText = 255;

bool finite(const fuse_msgs::Pose& pose) {
  const auto& p = pose.position();
  const auto& q = pose.orientation();
  return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z()) && std::isfinite(q.x()) &&
         std::isfinite(q.y()) && std::isfinite(q.z()) && std::isfinite(q.w());
}

/// Chunks that hold points (a loaded snapshot may carry empty ones).
std::size_t non_empty_chunks(const PointMap& map) {
  std::size_t n = 0;
  map.for_each_chunk([&](const PointChunk& c) { n += c.points.empty() ? 0 : 1; });
  return n;
}

void set_reply_error(fuse_msgs::MapControlReply& reply, fuse_msgs::RpcStatus status, const std::string& message) {
  reply.error(status);
  reply.error_message(message.substr(0, kMaxErrorText));
  log()->warn("map/control: {}", message);
}


std::uint64_t counter_of(const MapServerStats& s, const std::string& name) {
  const auto it = s.counters.find(name);
  return it == s.counters.end() ? 0 : it->second;
}

/// The recently active sessions' acknowledgements, newest first, as many as map/status carries.
std::vector<fuse_msgs::SessionAck> session_acks(const MapServerCore& core) {
  std::vector<fuse_msgs::SessionAck> out;
  for (const auto& [session, acked] : core.recent_sessions(fuse_msgs::MAX_STATUS_SESSIONS)) {
    fuse_msgs::SessionAck a;
    a.session(session);
    a.acked_sequence(acked);
    out.push_back(a);
  }
  return out;
}

}  // namespace

const char* refusal_reason(const fuse_msgs::MapObservation& o) {
  if (o.session() == 0) return "refused_session_zero";
  if (o.sequence_number() == 0) return "refused_sequence_zero";
  if (o.lowest_unacked() > o.sequence_number()) return "refused_lowest_unacked_above_sequence";
  if (!std::isfinite(o.t())) return "refused_time_not_finite";
  if (!finite(o.sensor_pose())) return "refused_pose_not_finite";
  if (o.points().size() > fuse_msgs::MAX_SCAN_POINTS) return "refused_too_many_points";
  return nullptr;
}

MapService::MapService(const MapServerConfig& config, transport::Participant& participant,
                       std::shared_ptr<service::Ros2Output> ros2, double ros2_period_s)
    : core_(std::make_unique<MapServerCore>(config)),
      ros2_(std::move(ros2)),
      ros2_period_(ros2_period_s),
      saved_maps_(config.saved_maps()),
      chunks_(participant, transport::topics::kMapChunk),
      status_(participant, transport::topics::kMapStatus),
      reported_(log()) {
  // The core has logged every problem of the load; health and status carry a summary.
  const LoadReport& report = core_->load_report();
  if (!report.clean()) {
    const std::string summary = "map load: " + std::to_string(report.problems.size()) +
                                " problem(s), the good part is kept; first: " + report.problems.front();
    count("load_problems", report.problems.size());
    set_error(summary);
    log()->warn("{}", summary);
  }

  // The whole map once, so that replicas (transient-local, latest per chunk) find it, and the
  // acknowledgements as loaded, so that no sender reads 0 for a session the map holds.
  refresh_stats();
  publish_all_chunks();
  publish_status();

  worker_alive_ns_ = std::chrono::steady_clock::now().time_since_epoch().count();
  worker_ = std::thread([this] { run(); });
  try {
    observations_ = std::make_unique<transport::Subscriber<fuse_msgs::MapObservation>>(
        participant, transport::topics::kObservation,
        [this](const fuse_msgs::MapObservation& o) { on_observation(o); },
        [this](const std::string& reason) { on_malformed(reason); });
    control_ = std::make_unique<ControlServer>(
        participant, transport::services::kMapControl,
        [this](const fuse_msgs::MapControlRequest& req, fuse_msgs::MapControlReply& rep) { on_control(req, rep); });
    control_->track_callers();
  } catch (...) {
    stop();
    throw;
  }
  log()->info("serving {}: {} points in {} chunks, epoch {}, mode {}", config.directory, core_->map().num_points(),
              core_->map().num_chunks(), core_->epoch(), core_->mode());
}

MapService::~MapService() { stop(); }

void MapService::stop() {
  // Inputs first: the RPC thread may be waiting for the worker, which is still running.
  observations_.reset();
  control_.reset();
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    stop_ = true;
  }
  queue_cv_.notify_all();
  if (worker_.joinable()) {
    worker_.join();
    if (const std::size_t pending = core_->stats().pending; pending > 0) {
      log()->warn("stopping with {} observations not journaled (pending): unacknowledged, their senders still hold "
                   "them",
                   pending);
    }
  }
  std::lock_guard<std::mutex> lock(health_mutex_);
  state_ = "stopping";
}

double MapService::worker_silence_s() const {
  const std::chrono::steady_clock::duration beat(worker_alive_ns_.load());
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch() - beat).count();
}

service::HealthSnapshot MapService::health() const {
  service::HealthSnapshot s;
  {
    std::lock_guard<std::mutex> lock(health_mutex_);
    s.state = state_;
    s.counters = counters_;
    for (const auto& [name, value] : reported_.map()) s.counters[name] += value;
    s.last_error = last_error_;
  }
  return s;
}

// ---- DDS threads ----------------------------------------------------------------------------

void MapService::on_observation(const fuse_msgs::MapObservation& observation) {
  count("observations_received");
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (stop_) return;
    if (queued_observations_ < kMaxQueuedObservations) {
      queue_.push_back(Job{std::make_unique<fuse_msgs::MapObservation>(observation), {}});
      ++queued_observations_;
      queue_cv_.notify_one();
      return;
    }
  }
  count("observations_dropped_queue_full");  // unacknowledged: the sender re-sends it
}

void MapService::on_malformed(const std::string& reason) {
  report("observations_malformed", "malformed observation sample: " + reason);
}

void MapService::on_control(const fuse_msgs::MapControlRequest& request, fuse_msgs::MapControlReply& reply) {
  // Run on the worker, between observations, and wait: the core has one caller.
  // Who asked (the sending participant, with its certificate's subject where the vendor tells it):
  // every control request is logged with it.
  const std::string caller = control_->caller();
  std::packaged_task<void()> task([&] { handle_control(request, caller, reply); });
  std::future<void> done = task.get_future();
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    if (stop_) throw std::runtime_error("fuse-map is stopping");
    queue_.push_back(Job{nullptr, [&task] { task(); }});
  }
  queue_cv_.notify_one();
  done.get();  // rethrows: the RPC server then answers RPC_INTERNAL_ERROR
}

// ---- worker thread --------------------------------------------------------------------------

void MapService::run() {
  for (;;) {
    Job job;
    bool have_job = false;
    {
      std::unique_lock<std::mutex> lock(queue_mutex_);
      // A retry that is due (soon) does not wait for the next beat.
      auto until = std::chrono::steady_clock::now() + kWorkerBeat;
      if (retry_at_) until = std::min(until, *retry_at_);
      queue_cv_.wait_until(lock, until, [this] { return stop_ || !queue_.empty(); });
      if (stop_) return;  // queued observations stay unacknowledged
      if (!queue_.empty()) {
        job = std::move(queue_.front());
        queue_.pop_front();
        if (job.observation) --queued_observations_;
        have_job = true;
      }
    }
    try {
      if (have_job && job.observation) {
        handle_observation(*job.observation);
      } else if (have_job) {
        job.control();
      }
      retry_if_due();
      publish_ros2_map_if_due();
    } catch (const std::exception& e) {
      // Not a write failure (the core keeps those pending): e.g. a chunk that failed to encode.
      set_error(std::string("worker: ") + e.what());
      report("worker_errors", std::string("worker: ") + e.what());
    }
    refresh_stats();
    worker_alive_ns_ = std::chrono::steady_clock::now().time_since_epoch().count();
  }
}

void MapService::retry_if_due() {
  const auto now = std::chrono::steady_clock::now();
  if (!core_->degraded()) {
    retry_at_.reset();
    return;
  }
  const auto interval = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(core_->config().retry_interval_s));
  if (!retry_at_) {
    retry_at_ = now + interval;  // the failure just happened: try again after one interval
    return;
  }
  if (now < *retry_at_) return;
  const MapRetryResult r = core_->retry();
  retry_at_ = r.more ? now : now + interval;
  if (r.journaled == 0) return;
  count("observations_applied", r.journaled);  // their points were applied (and published) on arrival
  refresh_stats();
  publish_status();
}

void MapService::publish_ros2_map_if_due() {
  if (!ros2_ || !ros2_map_changed_ || std::chrono::steady_clock::now() < ros2_next_map_) return;
  std::vector<float> xyz;
  xyz.reserve(3 * core_->map().num_points());
  core_->map().for_each_chunk([&](const PointChunk& c) {
    for (const Eigen::Vector3f& p : c.points) xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
  });
  ros2_->map(last_observation_t_, xyz);
  ros2_map_changed_ = false;
  ros2_next_map_ = std::chrono::steady_clock::now() +
                   std::chrono::duration_cast<std::chrono::steady_clock::duration>(ros2_period_);
}

void MapService::handle_observation(const fuse_msgs::MapObservation& o) {
  if (const char* reason = refusal_reason(o)) {
    count("observations_refused");
    report(reason, "observation session " + std::to_string(o.session()) + " sequence " +
                       std::to_string(o.sequence_number()) + " refused: " + reason);
    return;
  }
  if (std::isfinite(o.t())) last_observation_t_ = std::max(last_observation_t_, o.t());

  std::vector<Eigen::Vector3f> points;
  points.reserve(o.points().size());
  std::size_t not_finite = 0;
  for (const fuse_msgs::Point3f& p : o.points()) {
    points.emplace_back(p.x(), p.y(), p.z());
    if (!points.back().allFinite()) ++not_finite;
  }
  if (not_finite > 0) count("points_not_finite", not_finite);  // the core drops them
  const Eigen::Vector3d gravity(o.gravity().x(), o.gravity().y(), o.gravity().z());
  constexpr double kMaxGravityTilt = 0.35;  // rad: a session's gravity this far off −z is not a map frame's
  if (gravity.squaredNorm() > 0.0 && !core_->note_gravity(gravity, kMaxGravityTilt)) {
    count("observation_gravity_refused");  // the points are still taken
  }

  const MapApplyResult r =
      core_->apply(o.session(), o.sequence_number(), o.t(), points, o.lowest_unacked());
  if (r.rejected > not_finite) count("points_out_of_range", r.rejected - not_finite);
  const char* outcome = r.duplicate ? "duplicate" : r.applied ? "applied" : r.pending ? "pending" : "frozen";
  if (r.duplicate) {
    count("observations_duplicate");
  } else if (r.applied) {
    count("observations_applied");
    count("points_inserted", r.inserted);
  } else if (r.pending) {
    count("points_inserted", r.inserted);  // applied and served now; counted applied once journaled
  } else {
    count("observations_frozen");  // localization: acknowledged, the map unchanged
  }
  log()->debug("observation {}:{} ({} points): {}, {} inserted, {} chunks changed, acknowledged up to {}",
               o.session(), o.sequence_number(), o.points().size(), outcome, r.inserted, r.changed_chunks.size(),
               r.acked);
  refresh_stats();

  for (const std::uint64_t key : r.changed_chunks) {
    if (const PointChunk* chunk = core_->map().chunk(key)) publish_chunk(*chunk);
  }
  publish_status();
}

void MapService::handle_control(const fuse_msgs::MapControlRequest& request, const std::string& caller,
                                fuse_msgs::MapControlReply& reply) {
  count("control_requests");
  switch (request.command()) {
    case fuse_msgs::MAP_STATS:
      break;
    case fuse_msgs::MAP_SET_MODE: {
      const std::string mode = request.mode().to_string();
      if (mode != "mapping" && mode != "localization") {
        set_reply_error(reply, fuse_msgs::RPC_BAD_REQUEST, "unknown mode '" + mode + "' (mapping | localization)");
        break;
      }
      core_->set_mode(mode);
      publish_status();
      break;
    }
    case fuse_msgs::MAP_SAVE:
      save_map(request.path().to_string(), reply);
      break;
    case fuse_msgs::MAP_LOAD:
      load_map(request.path().to_string(), request.other_system(), reply);
      break;
    default:
      set_reply_error(reply, fuse_msgs::RPC_BAD_REQUEST,
                      "unknown command " + std::to_string(static_cast<int>(request.command())));
  }
  if (reply.error() != fuse_msgs::RPC_OK) count("control_errors");
  {
    static const std::map<int, std::string> kNames{{fuse_msgs::MAP_STATS, "stats"}, {fuse_msgs::MAP_SET_MODE, "mode"},
                                                   {fuse_msgs::MAP_SAVE, "save"}, {fuse_msgs::MAP_LOAD, "load"}};
    const auto name = kNames.find(static_cast<int>(request.command()));
    std::string what = name != kNames.end() ? name->second : "command " + std::to_string(static_cast<int>(request.command()));
    if (request.command() == fuse_msgs::MAP_SET_MODE) what += " " + request.mode().to_string();
    if (request.command() == fuse_msgs::MAP_SAVE || request.command() == fuse_msgs::MAP_LOAD) {
      what += " '" + request.path().to_string() + "'";
    }
    if (request.command() == fuse_msgs::MAP_LOAD && request.other_system()) what += " --other-system";
    const std::string who = caller.empty() ? "an unknown participant" : caller;
    if (reply.error() == fuse_msgs::RPC_OK) {
      if (request.command() == fuse_msgs::MAP_STATS) {
        log()->debug("control: {} from {}: ok", what, who);
      } else {
        log()->info("control: {} from {}: ok", what, who);
      }
    } else {
      log()->warn("control: {} from {}: {}", what, who, reply.error_message().to_string());
    }
  }

  const MapServerStats s = core_->stats();
  reply.mode(s.mode);
  reply.epoch(s.epoch);
  reply.points(s.points);
  reply.chunks(static_cast<std::uint32_t>(non_empty_chunks(core_->map())));
  reply.acked_sequence(core_->acked(core_->newest_session()));
  reply.journal_records(s.journal_records);
  reply.state(s.degraded ? "degraded" : "running");
  reply.state_reason(s.degraded_reason.substr(0, kMaxErrorText));
  reply.journal_errors(counter_of(s, "journal_errors"));
  reply.pending_observations(s.pending);
  reply.pending_bytes(s.pending_bytes);
  reply.pending_dropped(counter_of(s, "pending_dropped"));
  const LoadReport& load = core_->load_report();
  reply.load_bytes_skipped(load.bytes_skipped());
  reply.load_damaged_ranges(static_cast<std::uint32_t>(load.damaged.size()));
  reply.load_observations_lost(load.journal_records_lost);
  reply.load_chunks_lost(load.chunks_dropped);
  reply.sessions(session_acks(*core_));
}

std::optional<std::filesystem::path> MapService::saved_map(const std::string& name, const std::string& refusal,
                                                           fuse_msgs::MapControlReply& reply) {
  std::string why;
  std::optional<std::filesystem::path> resolved = resolve_map_name(saved_maps_, name, why);
  if (!resolved) {
    // The same answer whatever lies at a path: no oracle for which files exist.
    report("control_refused", refusal + ": " + why);
    set_reply_error(reply, fuse_msgs::RPC_BAD_REQUEST, refusal + ": " + why);
  }
  return resolved;
}

void MapService::save_map(const std::string& name, fuse_msgs::MapControlReply& reply) {
  std::filesystem::path file;  // empty: a snapshot of the map directory itself
  if (!name.empty()) {
    const std::optional<std::filesystem::path> resolved = saved_map(name, "save refused", reply);
    if (!resolved) return;
    file = *resolved;
  }
  try {
    if (!file.empty()) std::filesystem::create_directories(saved_maps_);
    // Absolute: the caller runs in another directory.
    const std::string path = std::filesystem::absolute(core_->save(file)).string();
    reply.path(path);
    log()->info("control: saved the map ({} points) to {}", core_->map().num_points(), path);
  } catch (const std::exception& e) {
    set_reply_error(reply, fuse_msgs::RPC_INTERNAL_ERROR, std::string("save failed: ") + e.what());
  }
}

void MapService::load_map(const std::string& name, bool other_system, fuse_msgs::MapControlReply& reply) {
  const std::optional<std::filesystem::path> resolved = saved_map(name, "load refused, the map is unchanged", reply);
  if (!resolved) return;
  const std::string path = resolved->string();
  // A map another system recorded (another vehicle, another site) replaces this one only when
  // the request says so, and that is logged.
  MapMeta recorded;
  const std::string& own = core_->config().system_name;
  if (MapStorage::read_snapshot_header(path, recorded) && recorded.system_name != own) {
    const std::string whose = "'" + name + "' was recorded by system '" + recorded.system_name + "', not by this one ('" +
                              own + "')";
    if (!other_system) {
      report("control_refused", "load refused, the map is unchanged: " + whose + " (load it with --other-system)");
      set_reply_error(reply, fuse_msgs::RPC_BAD_REQUEST,
                      "load refused, the map is unchanged: " + whose + "; load it with --other-system to replace "
                      "this system's map with it");
      return;
    }
    report("foreign_maps_loaded", "control: loading " + whose + ", as asked (--other-system)");
  }
  log()->info("control: loading {}", path);
  std::map<std::uint64_t, std::uint64_t> before;  // key -> revision of the map being replaced
  core_->map().for_each_chunk([&](const PointChunk& c) { before[c.key] = c.revision; });

  LoadReport report;
  try {
    report = core_->load(path);
  } catch (const MapStorageError& e) {
    set_reply_error(reply, fuse_msgs::RPC_INTERNAL_ERROR,
                    std::string("load failed, the map is unchanged: ") + e.what());
    return;
  }
  if (!report.snapshot_ok) {
    const std::string why = report.problems.empty() ? "not a readable snapshot" : report.problems.front();
    set_reply_error(reply, fuse_msgs::RPC_BAD_REQUEST, "cannot load '" + path + "', the map is unchanged: " + why);
    return;
  }
  if (!report.clean()) {
    set_error("load " + path + ": " + std::to_string(report.problems.size()) +
              " problem(s), the good part is kept; first: " + report.problems.front());
  }

  // The new epoch everywhere, and an empty chunk where the old map had one the new map lacks, so
  // that a replica drops it.
  publish_all_chunks();
  for (const auto& [key, revision] : before) {
    if (core_->map().chunk(key) != nullptr) continue;
    PointChunk empty;
    empty.key = key;
    empty.coord = PointMap::unpack_key(key);
    empty.revision = revision + 1;
    publish_chunk(empty);
  }
  publish_status();
  reply.path(std::filesystem::absolute(path).string());
}

void MapService::publish_chunk(const PointChunk& chunk) {
  if (chunk.points.size() > kMaxChunkPoints) {
    report("chunks_too_large", "chunk (" + std::to_string(chunk.coord.x()) + ", " + std::to_string(chunk.coord.y()) +
                                   ", " + std::to_string(chunk.coord.z()) + ") holds " +
                                   std::to_string(chunk.points.size()) + " points, more than a map/chunk sample carries (" +
                                   std::to_string(kMaxChunkPoints) + "): not published");
    return;
  }
  fuse_msgs::MapChunk m;
  m.key(chunk.key);
  m.epoch(core_->epoch());
  m.revision(chunk.revision);
  m.ix(chunk.coord.x());
  m.iy(chunk.coord.y());
  m.iz(chunk.coord.z());
  m.chunk_size(static_cast<float>(core_->map().chunk_size()));
  m.points().resize(chunk.points.size());
  for (std::size_t i = 0; i < chunk.points.size(); ++i) {
    m.points()[i].x(chunk.points[i].x());
    m.points()[i].y(chunk.points[i].y());
    m.points()[i].z(chunk.points[i].z());
  }
  count(chunks_.publish(m) ? "chunks_published" : "chunk_publish_failures");
  ros2_map_changed_ = true;
}

void MapService::publish_all_chunks() {
  core_->map().for_each_chunk([&](const PointChunk& c) { publish_chunk(c); });
}

void MapService::publish_status() {
  const MapServerStats s = core_->stats();
  fuse_msgs::MapStatus m;
  m.epoch(s.epoch);
  m.mode(s.mode);
  m.session(core_->newest_session());
  m.acked_sequence(core_->acked(core_->newest_session()));
  m.sessions(session_acks(*core_));
  m.points(s.points);
  m.chunks(static_cast<std::uint32_t>(non_empty_chunks(core_->map())));
  m.observations_applied(s.observations_applied);
  m.journal_records(s.journal_records);
  if (const auto& g = core_->gravity()) {
    m.gravity().x(g->x());
    m.gravity().y(g->y());
    m.gravity().z(g->z());
  }
  {
    std::lock_guard<std::mutex> lock(health_mutex_);
    m.last_error(last_error_.substr(0, kMaxErrorText));
  }
  count(status_.publish(m) ? "statuses_published" : "status_publish_failures");
}

void MapService::refresh_stats() {
  const MapServerStats s = core_->stats();
  const LoadReport& load = core_->load_report();
  std::lock_guard<std::mutex> lock(health_mutex_);
  counters_["map_epoch"] = s.epoch;
  counters_["map_points"] = s.points;
  counters_["map_chunks"] = s.chunks;
  counters_["map_observations_applied"] = s.observations_applied;
  counters_["journal_records"] = s.journal_records;
  counters_["snapshots"] = s.snapshots;
  counters_["localization"] = s.mode == "localization" ? 1 : 0;
  counters_["pending_observations"] = s.pending;
  counters_["pending_bytes"] = s.pending_bytes;
  counters_["load_bytes_skipped"] = load.bytes_skipped();
  counters_["load_damaged_ranges"] = load.damaged.size();
  counters_["load_observations_lost"] = load.journal_records_lost;
  counters_["load_chunks_lost"] = load.chunks_dropped;
  for (const auto& [name, value] : s.counters) counters_[name] = value;  // journal_errors, pending_dropped, ...
  const std::string state = s.degraded ? "degraded" : "running";
  if (state != state_ && state_ != "stopping") {
    if (s.degraded) {
      log()->error("degraded: {}", s.degraded_reason);
    } else if (state_ == "degraded") {
      log()->info("running again: every observation is journaled and the map directory is writable");
    }
    state_ = state;
  }
  if (s.degraded && s.degraded_reason != degraded_reason_) last_error_ = s.degraded_reason;
  degraded_reason_ = s.degraded_reason;
}

std::uint64_t MapService::count(const std::string& counter, std::uint64_t n) {
  std::lock_guard<std::mutex> lock(health_mutex_);
  return counters_[counter] += n;
}

void MapService::report(const std::string& counter, const std::string& message) {
  std::lock_guard<std::mutex> lock(health_mutex_);
  reported_.count(counter, message);
}

void MapService::set_error(const std::string& error) {
  std::lock_guard<std::mutex> lock(health_mutex_);
  last_error_ = error;
}

}  // namespace fuse::map_service

#include "update_service.hpp"

#include <cmath>
#include <thread>

#include "fuse/core/logging.hpp"
#include "fuse/estimation/estimator.hpp"
#include "fuse/io/cdr_codec.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/service/notify.hpp"
#include "fuse/service/runtime.hpp"

namespace fuse::service {

namespace {
constexpr const char* kName = "fuse-update";
/// While the backlog waits for fuse-state, it asks again this often.
constexpr std::chrono::milliseconds kHoldRetry{50};
using Clock = std::chrono::steady_clock;
using Ms = std::chrono::milliseconds;
}  // namespace

UpdateService::UpdateService(const SystemConfig& config, transport::Participant& participant)
    : config_(config),
      session_(transport::random_id()),
      updater_(config.estimator),
      monitor_(config.estimator.tracking),
      frame_(config.estimator),
      backlog_(config.estimator.preprocess, config.update.max_backlog_s),
      unacked_({config.update.max_unacked, config.update.max_unacked_bytes, config.update.resend_after_s}),
      counters_(logger(kName)),
      corrections_(participant, transport::topics::kCorrection),
      observations_(participant, transport::topics::kObservation),
      world_scans_(participant, transport::topics::kWorldScan),
      history_(participant, transport::services::kHistory) {
  auto bad = [this](const char* topic) {
    return [this, topic](const std::string& why) {
      std::lock_guard<std::mutex> lock(mutex_);
      counters_.count(std::string("malformed_") + topic, std::string("malformed ") + topic + " sample: " + why);
      last_error_ = why;
    };
  };
  chunk_sub_ = std::make_unique<transport::Subscriber<fuse_msgs::MapChunk>>(
      participant, transport::topics::kMapChunk, [this](const fuse_msgs::MapChunk& m) { on_chunk(m); }, bad("chunk"));
  status_sub_ = std::make_unique<transport::Subscriber<fuse_msgs::MapStatus>>(
      participant, transport::topics::kMapStatus, [this](const fuse_msgs::MapStatus& m) { on_status(m); }, bad("status"));
  corrected_sub_ = std::make_unique<transport::Subscriber<fuse_msgs::StateEstimate>>(
      participant, transport::topics::kCorrected, [this](const fuse_msgs::StateEstimate& m) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (std::isfinite(m.t())) corrected_t_ = std::max(corrected_t_, m.t());
      });
  // Scans are decoded by the direct codec (io::decode_scan, checked in process()): a tenth of the cost of the
  // generated type's decoding for ~20k points, on the scan's way to the update.
  scan_sub_ = std::make_unique<transport::RawSubscriber<fuse_msgs::LidarScan>>(
      participant, transport::topics::kLidarScan, [this](const std::uint8_t* data, std::size_t size) { on_scan(data, size); });
  set_pose_server_ = std::make_unique<transport::RpcServer<fuse_msgs::SetPoseRequest, fuse_msgs::SetPoseReply>>(
      participant, transport::services::kSetPose,
      [this](const fuse_msgs::SetPoseRequest& req, fuse_msgs::SetPoseReply& rep) { on_set_pose(req, rep); },
      transport::Dispatch::kWorker);  // waits for the verdict
  health_ = std::make_unique<HealthReporter>(participant, kName, config.health.period_s, config.health.instance_window_s, [this] { return health(); });
  if (config.ros2.enabled) {
    ros2_ = std::make_unique<Ros2Output>(participant, config.ros2, Ros2Output::Outputs{false, true, false});
    ros2_->attach(*health_);
  }
  logger(kName)->info("session {:016x}", session_);
}

UpdateService::~UpdateService() {
  // Stop the callbacks before the members they use go away.
  {
    std::lock_guard<std::mutex> lock(mutex_);
    pose_requests_.clear();
  }
  verdict_cv_.notify_all();
  set_pose_server_.reset();
  scan_sub_.reset();
  corrected_sub_.reset();
  status_sub_.reset();
  chunk_sub_.reset();
}

void UpdateService::on_scan(const std::uint8_t* data, std::size_t size) {
  LidarScan scan;
  try {
    scan = io::decode_scan(io::kLidarScanSchemaName, data, size);
  } catch (const io::InputError& e) {
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.count("malformed_scan", std::string("scan sample refused: ") + e.what());
    last_error_ = e.what();
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (scan.t_end <= corrected_t_) {  // re-delivered to a restarted fuse-update: answered before
      counters_.add("scans_already_corrected");
      return;
    }
    const double t_end = scan.t_end;
    if (const std::size_t dropped = backlog_.push(std::move(scan))) {
      counters_.add("scans_dropped_backlog", dropped - 1);
      counters_.count("scans_dropped_backlog",
                      fmt::format("scan backlog spans more than update.max_backlog_s = {:.1f} s at t={:.3f}: {} oldest "
                                  "scan(s) dropped unprocessed",
                                  config_.update.max_backlog_s, t_end, dropped));
      last_error_ = "scan backlog full: scans dropped unprocessed";
    }
  }
  cv_.notify_one();
}

void UpdateService::on_chunk(const fuse_msgs::MapChunk& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  // Once the replica follows an epoch, its chunks add nothing (the replica is written through);
  // chunks of a newer epoch are kept for the rebuild.
  if (state_ != "starting" && replica_complete_ && msg.epoch() <= replica_epoch_) return;
  auto it = chunks_.find(msg.key());
  if (it == chunks_.end() || msg.epoch() > it->second.epoch() ||
      (msg.epoch() == it->second.epoch() && msg.revision() >= it->second.revision())) {
    chunks_[msg.key()] = msg;
  }
}

void UpdateService::on_status(const fuse_msgs::MapStatus& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  status_ = msg;
  have_status_ = true;
  if (const auto acked = UnackedObservations::acked_in(msg, session_)) unacked_.acknowledge(*acked);
}

bool UpdateService::chunks_complete() const {
  if (!have_status_) return false;
  std::size_t n = 0;
  for (const auto& [key, c] : chunks_) n += (c.epoch() == status_.epoch() && !c.points().empty()) ? 1 : 0;
  return n >= status_.chunks();
}

void UpdateService::sync_map(double timeout_s) {
  // Wait for the map server's status, then for every chunk of its epoch (transient-local).
  const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
  auto complete = [this] { return chunks_complete(); };
  for (;;) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (complete() || Clock::now() >= end || stop_requested()) break;
    }
    notifier().watchdog();
    std::this_thread::sleep_for(Ms(10));
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (!have_status_) {
    counters_.count("map_server_unavailable", "no map server status: the replica starts empty, and is rebuilt once the "
                                              "map server's map has arrived");
    replica_complete_ = false;
    state_ = "running";
    return;
  }
  replica_complete_ = complete();
  if (!replica_complete_) {
    counters_.count("map_sync_incomplete", "not every chunk of the map arrived before the sync timeout: the replica is "
                                           "rebuilt once they have");
  }
  updater_.reset_map();
  std::vector<Eigen::Vector3f> points;
  std::size_t n = 0;
  for (const auto& [key, c] : chunks_) {
    if (c.epoch() != status_.epoch()) continue;
    points.clear();
    for (const auto& p : c.points()) points.emplace_back(p.x(), p.y(), p.z());
    updater_.map().insert(points);
    n += points.size();
  }
  if (replica_complete_) chunks_.clear();  // else kept: the rest are still to come
  replica_epoch_ = status_.epoch();
  replica_mode_ = status_.mode();
  if ((replica_mode_ == "mapping" || replica_mode_ == "localization") && frame_.writes_map()) {
    updater_.set_map_mode(replica_mode_);
  }
  state_ = "running";
  logger(kName)->info("replica of map epoch {} built from the map server: {} points; mode {}", replica_epoch_, n,
                      replica_mode_);
  frame_.map_replaced(updater_, map_context(), last_scan_t_);
}

void UpdateService::run() {
  sync_map(config_.update.map_sync_timeout_s);
  while (!stop_requested()) {
    notifier().watchdog();  // the loop wakes at least every 50 ms, scans or not
    LidarScan scan;
    bool have_scan = false;
    bool resync = false;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (holding_) {
        // fuse-state could not answer: keep what arrives, compacted, and ask again shortly.
        cv_.wait_for(lock, kHoldRetry, [] { return stop_requested(); });
      } else {
        cv_.wait_for(lock, Ms(50), [this] { return !backlog_.empty(); });
      }
      if (backlog_.size() > config_.update.compact_after) {
        counters_.add("scans_compacted", backlog_.compact_waiting(config_.update.compact_after));
      }
      if (have_status_ && status_.epoch() != replica_epoch_) resync = true;
      if (!replica_complete_ && chunks_complete()) resync = true;  // the rest of the map has arrived
      if (have_status_ && status_.mode() != replica_mode_ && !resync) {
        replica_mode_ = status_.mode();
        if ((replica_mode_ == "mapping" || replica_mode_ == "localization") && frame_.writes_map()) {
          updater_.set_map_mode(replica_mode_);
          logger(kName)->info("map mode is now {}", replica_mode_);
        } else if (!frame_.writes_map()) {
          logger(kName)->info("map mode is now {}: taken once the session is located in the map", replica_mode_);
        }
      }
      if (!resync && !backlog_.empty()) {
        scan = backlog_.take_front();
        have_scan = true;
      }
    }
    if (resync) {
      logger(kName)->info(replica_complete_ ? "the map server replaced its map: rebuilding the replica"
                                            : "the map server's map has arrived: rebuilding the replica from it");
      sync_map(config_.update.map_sync_timeout_s);
      continue;
    }
    if (have_scan && process(scan) == Outcome::kHold) {
      std::lock_guard<std::mutex> lock(mutex_);
      backlog_.return_front(std::move(scan));
      if (!holding_) {
        logger(kName)->warn("fuse-state cannot answer: holding the scans (at most update.max_backlog_s = {:.1f} s) "
                            "until it can",
                            config_.update.max_backlog_s);
        state_ = "waiting";
      }
      holding_ = true;
    } else if (have_scan) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (holding_) {
        logger(kName)->info("fuse-state answers again: processing the {} held scan(s)", backlog_.size() + 1);
        if (state_ == "waiting") state_ = "running";
      }
      holding_ = false;
    }
    resend_unacked(false);
  }
  health_->publish_now();
}

void UpdateService::publish_skipped(const LidarScan& scan) {
  fuse_msgs::Correction c;
  c.t(scan.t_end);
  c.scan_sequence(scan.sequence);
  c.result(fuse_msgs::SCAN_SKIPPED);
  corrections_.publish(c);
}

UpdateService::Fetch UpdateService::fetch_history(const LidarScan& scan, StateHistory& out) {
  const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                      std::chrono::duration<double>(config_.update.history_deadline_s));
  fuse_msgs::HistoryRequest req;
  req.t_start(scan.t_start);
  req.t_end(scan.t_end);
  req.after_correction(last_posterior_ ? last_posterior_->t : 0.0);
  for (;;) {
    const auto left = std::chrono::duration_cast<Ms>(end - Clock::now());
    if (stop_requested()) return Fetch::kHold;
    if (left.count() <= 0) {
      std::lock_guard<std::mutex> lock(mutex_);
      counters_.count("history_wait_timeout", "fuse-state did not cover the scan ending at t=" + std::to_string(scan.t_end) +
                                                  " in time: scan skipped");
      return Fetch::kSkip;
    }
    auto result = history_.call(req, left);
    if (result.status == fuse_msgs::RPC_NOT_READY) {
      if (result.reply.recovering()) return Fetch::kHold;  // fuse-state restarted: it answers after its recovery
      if (!result.reply.initialised()) {
        std::lock_guard<std::mutex> lock(mutex_);
        counters_.count("scan_before_init", "scan before the state is initialised, skipped");
        return Fetch::kSkip;
      }
      notifier().watchdog();
      std::this_thread::sleep_for(Ms(1));
      continue;
    }
    // No fuse-state answered within the deadline: it is down or restarting. Hold the scan.
    if (result.status == fuse_msgs::RPC_UNAVAILABLE) return Fetch::kHold;
    std::lock_guard<std::mutex> lock(mutex_);
    if (!result.ok()) {
      // A scan older than fuse-state's history: one a restarted fuse-state restored past (it was
      // answered before its restart), not a fault; anything else is.
      const bool too_old = result.message.find("older than the state history") != std::string::npos;
      counters_.count(too_old ? "scans_older_than_state" : "history_refused",
                      "fuse-state refused the history request: " + result.message);
      return Fetch::kSkip;
    }
    std::vector<StateHistory::Entry> entries;
    try {
      for (const auto& e : result.reply.entries()) entries.push_back(from_msg(e));
    } catch (const InvalidSample& e) {
      counters_.count(e.reason(), std::string("history reply refused: ") + e.what());
      return Fetch::kSkip;
    }
    if (entries.empty() || std::abs(entries.back().t - scan.t_end) > 1e-6) {
      counters_.count("history_invalid", "history reply does not end at the scan end");
      return Fetch::kSkip;
    }
    for (int r = 0; r < kStateDim; ++r) {
      for (int c = 0; c < kStateDim; ++c) {
        entries.back().P(r, c) = result.reply.covariance()[static_cast<std::size_t>(r * kStateDim + c)];
      }
    }
    if (!entries.back().P.allFinite()) {
      counters_.count("history_invalid", "history covariance is not finite");
      return Fetch::kSkip;
    }
    if (!valid(result.reply.map_frame())) {
      counters_.count("history_invalid", "history reply names an unknown map frame state " +
                                             std::to_string(static_cast<long long>(result.reply.map_frame())));
      return Fetch::kSkip;
    }
    out.assign(entries, result.reply.last_correction_time());
    slice_frame_ = WorldFrame{result.reply.map_frame(), result.reply.frame_epoch()};
    slice_last_correction_t_ = result.reply.last_correction_time();
    return Fetch::kOk;
  }
}

void UpdateService::bring_up_to_date(StateHistory& history, double slice_last_correction_t) {
  // fuse-state applies a correction when it arrives; a slice served before that (a backlog
  // processed back to back, fuse-state restarted from an older posterior) was propagated from an
  // older one. Applying ours at its time and re-propagating the slice's IMU after it gives what
  // fuse-state's history holds once it has applied it (same StateHistory code, same inputs), so
  // the next scan's prior does not depend on which process was faster.
  constexpr double kSameTime = 1e-6;
  if (!last_posterior_ || last_posterior_->t <= slice_last_correction_t + kSameTime) return;
  const double t = last_posterior_->t;
  if (t < history.oldest_time() - kSameTime || t > history.newest().t + kSameTime) return;  // not within the slice
  history.ensure_entry(t);
  history.correct(t, last_posterior_->x, last_posterior_->P);
  std::lock_guard<std::mutex> lock(mutex_);
  counters_.add("history_brought_up_to_date");
}

UpdateService::Outcome UpdateService::process(LidarScan& scan) {
  try {
    check_scan(scan);
  } catch (const InvalidSample& e) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      counters_.count(e.reason(), std::string("scan refused: ") + e.what());
      last_error_ = e.what();
    }
    publish_skipped(scan);
    return Outcome::kDone;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (scan.t_end <= corrected_t_) {  // corrected by an earlier instance while this one held it
      counters_.add("scans_already_corrected");
      return Outcome::kDone;
    }
  }
  if (scan.t_end <= last_scan_t_) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      counters_.count("scan_out_of_order", "scan ending at t=" + std::to_string(scan.t_end) + " is not newer than the last one, refused");
    }
    publish_skipped(scan);
    return Outcome::kDone;
  }
  StateHistory history(config_.estimator.history, config_.estimator.imu);
  switch (fetch_history(scan, history)) {
    case Fetch::kHold: return Outcome::kHold;
    case Fetch::kSkip:
      monitor_.on_refused_scan();
      publish_skipped(scan);
      return Outcome::kDone;
    case Fetch::kOk: break;
  }
  // Into this instance's world frame (fuse-state may not have applied its newest change yet), then
  // up to its newest posterior.
  FrameLocalizer::MapContext map;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    map = map_context();
    while (!pose_requests_.empty()) {
      frame_.request_pose(pose_requests_.front().id, pose_requests_.front().pose, pose_requests_.front().t);
      pose_checks_.push_back(pose_requests_.front().id);
      pose_requests_.pop_front();
    }
  }
  if (frame_.reconcile(slice_frame_, history, updater_, map)) last_posterior_.reset();
  bring_up_to_date(history, slice_last_correction_t_);
  last_scan_t_ = scan.t_end;
  // A lost track keeps trying: the scan is re-localised from a widened prior (as in fuse-run).
  if (monitor_.wants_relocalisation() && !frame_.frame().relocalizing()) widen_prior(history, scan.t_end, config_.estimator);
  ScanReport report;
  try {
    report = updater_.process(scan, history);
    monitor_.on_scan(report);
    const LocalizationEvent e = frame_.step(report, history, updater_, lost_for(monitor_));
    if (e.kind == LocalizationEvent::Kind::kTaken || e.kind == LocalizationEvent::Kind::kDropped) last_posterior_.reset();
    if (e.kind == LocalizationEvent::Kind::kConfirmed && (replica_mode_ == "mapping" || replica_mode_ == "localization")) {
      updater_.set_map_mode(replica_mode_);
    }
    after_localization_step(e);
  } catch (const DivergenceError& e) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      counters_.count("diverged", std::string("estimator diverged: ") + e.what());
      last_error_ = e.what();
      state_ = "degraded";
    }
    publish_skipped(scan);
    return Outcome::kDone;
  }
  if (report.moving_screened > 0) {
    // Points of the scan left out of the update and the observation as moving
    // (estimator.map.carve_lookback_s): counted where health shows the service's counters.
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.add("moving_points_screened", report.moving_screened);
  }
  const StateQuery q = history.query(scan.t_end);
  Posterior post{scan.t_end, scan.sequence, q.x, q.P};
  if (report.updated) {
    last_posterior_ = post;
  } else if (report.map_points > 0 && report.map_inserted == report.map_points) {
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.add("scans_seeding_map");  // the replica was empty: the scan is the map's first
  } else {
    // The prior goes back unchanged (SCAN_PRIOR_ONLY): fuse-state keeps propagating without a
    // correction. Said, with why, so that a stretch of them is not silent.
    const char* why = report.recovery ? "re-localisation not taken" : report.constraints == 0 ? "no constraint" : "no step";
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.count("scan_not_updated", fmt::format("scan ending at t={:.6f} gave no update ({}; {} constraints, map {} "
                                                    "points): the prior is sent back as it was",
                                                    scan.t_end, why, report.constraints, report.map_points));
  }
  fuse_msgs::Correction c = to_msg(post);
  c.result(report.updated ? fuse_msgs::SCAN_UPDATED : fuse_msgs::SCAN_PRIOR_ONLY);
  c.constraints_kept(static_cast<std::uint32_t>(report.constraints));
  c.constraints_rejected(
      static_cast<std::uint32_t>(report.rejected_no_neighbors + report.rejected_not_planar + report.rejected_screening));
  c.iterations(static_cast<std::uint32_t>(report.iterations));
  c.min_eigenvalue_translation(report.min_eig_translation);
  c.min_eigenvalue_rotation(report.min_eig_rotation);
  c.min_gamma(report.min_gamma);
  c.update_ms(report.ms_total);
  c.converged(report.converged);
  c.fit(report.match_fit);
  for (int r = 0; r < 6; ++r) {
    for (int k = 0; k < 6; ++k) c.map_drift()[static_cast<std::size_t>(r * 6 + k)] = report.map_drift(r, k);
  }
  switch (monitor_.status()) {
    case TrackingStatus::kTracking: c.tracking(fuse_msgs::TRACKING_OK); break;
    case TrackingStatus::kRelocalizing: c.tracking(fuse_msgs::TRACKING_RELOCALIZING); break;
    case TrackingStatus::kLost: c.tracking(fuse_msgs::TRACKING_LOST); break;
  }
  if (monitor_.status() != TrackingStatus::kTracking) {
    std::lock_guard<std::mutex> lock(mutex_);
    last_error_ = std::string(to_string(monitor_.status())) + ": " + monitor_.reason();
  }
  frame_.fill(c);
  corrections_.publish(c);
  publish_world_scan(scan);
  gravity_ = q.x.g;
  if (frame_.writes_map()) offer_to_map(scan.t_end);
  std::lock_guard<std::mutex> lock(mutex_);
  updater_counts_ = updater_.counters().map();
  counters_.add("scans_processed");
  if (report.updated) counters_.add("scans_updated");
  return Outcome::kDone;
}

void UpdateService::publish_world_scan(const LidarScan& scan) {
  const std::vector<Eigen::Vector3f>& points = updater_.last_scan_points();
  const bool fuse_viewer = world_scans_.matched() > 0, ros2_viewer = ros2_ && ros2_->scan_wanted();
  if (points.empty() || (!fuse_viewer && !ros2_viewer)) return;  // for viewers: without one, no work
  fuse_msgs::WorldScan m;
  m.t(scan.t_end);
  m.scan_sequence(scan.sequence);
  const Eigen::Isometry3d& T = updater_.last_T_world_lidar();
  m.sensor_pose(to_pose(T.translation(), T.linear()));
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f p = T.translation().cast<float>();
  m.points().resize(std::min(points.size(), kMaxWorldScanPoints));
  for (std::size_t i = 0; i < m.points().size(); ++i) {
    const Eigen::Vector3f w = R * points[i] + p;
    m.points()[i].x(w.x());
    m.points()[i].y(w.y());
    m.points()[i].z(w.z());
  }
  if (fuse_viewer) world_scans_.publish(m);
  if (ros2_viewer) {
    std::vector<float> xyz;
    xyz.reserve(3 * m.points().size());
    for (const fuse_msgs::Point3f& p3 : m.points()) xyz.insert(xyz.end(), {p3.x(), p3.y(), p3.z()});
    ros2_->scan(scan.t_end, xyz);
  }
}

void UpdateService::offer_to_map(double t) {
  const auto& points = updater_.last_world_points();
  if (points.empty()) return;
  fuse_msgs::MapObservation m;
  m.session(session_);
  m.sequence_number(++observation_sequence_);
  m.t(t);
  const Eigen::Isometry3d& T = updater_.last_T_world_lidar();
  m.sensor_pose(to_pose(T.translation(), T.linear()));
  if (gravity_.allFinite() && gravity_.norm() > 0.0) {
    const Eigen::Vector3d g = gravity_.normalized();
    m.gravity().x(g.x());
    m.gravity().y(g.y());
    m.gravity().z(g.z());
  }
  m.points().resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    m.points()[i].x(points[i].x());
    m.points()[i].y(points[i].y());
    m.points()[i].z(points[i].z());
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    m.lowest_unacked(unacked_.lowest_unacked(m.sequence_number()));
  }
  observations_.publish(m);
  std::lock_guard<std::mutex> lock(mutex_);
  for (const std::uint64_t sequence : unacked_.add(std::move(m), Clock::now())) {
    last_error_ = "map observation " + std::to_string(sequence) + " given up: the map server has not acknowledged it and " +
                  std::to_string(unacked_.size()) + " observations (" + std::to_string(unacked_.bytes()) +
                  " bytes) wait for it (update.max_unacked, update.max_unacked_bytes); the persisted map lacks it";
    counters_.count("observations_given_up", last_error_);
  }
}

void UpdateService::resend_unacked(bool all) {
  std::vector<fuse_msgs::MapObservation> resend;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    resend = unacked_.due(Clock::now(), all);
    if (!resend.empty()) counters_.add("observations_resent", resend.size());
  }
  for (const auto& m : resend) observations_.publish(m);
}

FrameLocalizer::MapContext UpdateService::map_context() const {
  FrameLocalizer::MapContext m;
  m.mode = have_status_ ? status_.mode() : config_.estimator.map.mode;
  if (have_status_) {
    const Eigen::Vector3d g(status_.gravity().x(), status_.gravity().y(), status_.gravity().z());
    if (g.allFinite() && g.norm() > 0.5) m.gravity = g.normalized();
  }
  return m;
}

void UpdateService::after_localization_step(const LocalizationEvent& e) {
  std::lock_guard<std::mutex> lock(mutex_);
  switch (e.kind) {
    case LocalizationEvent::Kind::kTaken: counters_.count("global_location_taken", e.message); break;
    case LocalizationEvent::Kind::kConfirmed: counters_.count("global_localized", e.message); break;
    case LocalizationEvent::Kind::kDropped:
      counters_.count("global_localization_dropped", "global localization dropped: " + e.message);
      break;
    case LocalizationEvent::Kind::kSearchStarted: counters_.count("lost_search", e.message); break;
    case LocalizationEvent::Kind::kNone: break;
  }
  if (const std::string problem = frame_.take_problem(); !problem.empty()) {
    counters_.count("global_localization_impossible", problem);
    last_error_ = problem;
  }
  localization_ = frame_.describe();
  relocalizing_ = frame_.frame().relocalizing();
  bool decided = false;
  for (auto it = pose_checks_.begin(); it != pose_checks_.end();) {
    const PoseVerdict v = frame_.verdict(*it);
    pose_verdicts_[*it] = v;
    if (v.result == fuse_msgs::SET_POSE_PENDING) {
      ++it;
      continue;
    }
    decided = true;
    counters_.count(v.result == fuse_msgs::SET_POSE_REFUSED ? "set_pose_refused" : "set_pose_accepted",
                    fmt::format("set-pose request {}: {}", *it, v.detail));
    it = pose_checks_.erase(it);
  }
  if (decided) verdict_cv_.notify_all();
}

void UpdateService::on_set_pose(const fuse_msgs::SetPoseRequest& req, fuse_msgs::SetPoseReply& rep) {
  const Eigen::Vector3d p(req.position().x(), req.position().y(), req.position().z());
  constexpr double kMaxCoordinate = 1e6;  // m: beyond any map
  std::string bad;
  if (!p.allFinite() || p.cwiseAbs().maxCoeff() > kMaxCoordinate) bad = "position must be finite and within 1e6 m";
  else if (!std::isfinite(req.yaw())) bad = "yaw must be finite";
  else if (!(req.std_xy() > 0.0 && req.std_xy() <= 100.0)) bad = "std_xy must be in (0, 100] m";
  else if (!(req.std_yaw() > 0.0 && req.std_yaw() <= M_PI)) bad = "std_yaw must be in (0, pi] rad";
  else if (!(req.wait_s() >= 0.0 && req.wait_s() <= 30.0)) bad = "wait_s must be in [0, 30] s";
  else if (!(std::isfinite(req.t()) && req.t() >= 0.0)) bad = "t must be finite and >= 0 (0: now)";
  std::unique_lock<std::mutex> lock(mutex_);
  if (!bad.empty()) {
    counters_.count("set_pose_bad_request", "set-pose request refused: " + bad);
    rep.error(fuse_msgs::RPC_BAD_REQUEST);
    rep.error_message(bad);
    return;
  }
  InitialPose pose;
  pose.position = p;
  pose.yaw = req.yaw();
  pose.std_xy = req.std_xy();
  pose.std_z = req.std_xy();  // an operator rarely knows the height better than the position
  pose.std_yaw = req.std_yaw();
  const std::uint64_t id = ++next_pose_id_;
  pose_requests_.push_back({id, pose, req.t()});
  pose_verdicts_[id] = PoseVerdict{};
  while (pose_verdicts_.size() > 16) pose_verdicts_.erase(pose_verdicts_.begin());
  logger(kName)->info("set-pose request {}: ({:.2f}, {:.2f}, {:.2f}) m, heading {:.1f} deg, sigma {:.2f} m / {:.1f} deg", id,
                      p.x(), p.y(), p.z(), req.yaw() * 180.0 / M_PI, req.std_xy(), req.std_yaw() * 180.0 / M_PI);
  cv_.notify_one();
  const auto until = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(req.wait_s()));
  verdict_cv_.wait_until(lock, until, [&] {
    const auto it = pose_verdicts_.find(id);
    return stop_requested() || it == pose_verdicts_.end() || it->second.result != fuse_msgs::SET_POSE_PENDING;
  });
  const auto it = pose_verdicts_.find(id);
  const PoseVerdict v = it != pose_verdicts_.end() ? it->second : PoseVerdict{};
  rep.result(v.result);
  rep.position().x(v.position.x());
  rep.position().y(v.position.y());
  rep.position().z(v.position.z());
  rep.yaw(v.yaw);
  rep.offset(v.offset);
  rep.turn(v.turn);
  rep.detail(v.result == fuse_msgs::SET_POSE_PENDING ? "still being checked: queries say relocalizing until it is decided"
                                                     : v.detail.substr(0, 255));
}

HealthSnapshot UpdateService::health() {
  std::lock_guard<std::mutex> lock(mutex_);
  HealthSnapshot s;
  s.state = state_;
  s.counters = counters_.map();
  if (relocalizing_ && state_ == "running") s.state = "relocalizing";  // searching the saved map
  for (const auto& [k, v] : updater_counts_) s.counters[k] += v;
  s.counters["observations_unacked"] = unacked_.size();
  s.counters["scans_queued"] = backlog_.size();
  s.counters["observations_unacked_bytes"] = unacked_.bytes();
  s.last_error = s.state == "relocalizing" ? "relocalizing: " + localization_ : last_error_;
  return s;
}

}  // namespace fuse::service

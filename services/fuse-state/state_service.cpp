#include "state_service.hpp"

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <optional>

#include "fuse/core/logging.hpp"
#include "fuse/service/notify.hpp"
#include "fuse/service/runtime.hpp"

namespace fuse::service {

namespace {
constexpr const char* kName = "fuse-state";
/// Requests further than this from the newest state are refused as absurd (not merely too old).
constexpr double kAbsurdTimeSpan = 86400.0;
/// Times beyond this (year 2286 as UNIX seconds) are refused whatever the state (as the client does).
constexpr double kMaxQueryTime = 1e10;
/// A history slice covers one scan: longer requests are refused.
constexpr double kMaxHistorySpan = 1.0;
/// A restored history whose newest IMU is this far past its last up-to-date entry is catching up
/// on held scans: odometry waits, and the latest state answered is the up-to-date one.
constexpr double kCatchUpS = 1.0;
/// Wall-clock silence of the IMU after which a scan ahead of it is coasted to (a lockstep replay
/// publishes the IMU before the scan, so only a real dropout is silent this long).
constexpr double kImuSilenceS = 0.25;
/// The same silence after a restore, before any IMU sample after the restored posterior has come:
/// the ingest's writer delivers the samples held during the restart over a second or so after
/// its reader matches, and a scan answered before them is extrapolated from one held sample
/// while the real samples behind it are dropped (imu_older_than_state; in the long chaos soak a
/// velocity 0.45 m/s off and 2.2 m of drift along the corridor before the map pulled it back).
constexpr double kRestartImuWaitS = 2.0;

void set_error(fuse_msgs::RpcStatus status, const std::string& message, fuse_msgs::QueryReply& rep) {
  rep.error(status);
  rep.error_message(message.substr(0, 255));
}
void set_error(fuse_msgs::RpcStatus status, const std::string& message, fuse_msgs::HistoryReply& rep) {
  rep.error(status);
  rep.error_message(message.substr(0, 255));
}

EstimatorConfig with_history(EstimatorConfig c, double history_s) {
  c.history.length_s = std::max(c.history.length_s, history_s);
  return c;
}

/// The reply's status when the estimator is not tracking: its own state, whatever t.
void mark(Tracking tracking, fuse_msgs::StateEstimate& e) {
  if (tracking == Tracking::kRelocalizing) e.status(fuse_msgs::STATUS_RELOCALIZING);
  if (tracking == Tracking::kLost) e.status(fuse_msgs::STATUS_LOST);
}
}  // namespace

const char* to_string(Tracking tracking) {
  switch (tracking) {
    case Tracking::kTracking: return "tracking";
    case Tracking::kRelocalizing: return "relocalizing";
    case Tracking::kLost: return "lost";
  }
  return "unknown";
}

StateService::StateService(const SystemConfig& config, transport::Participant& participant,
                           const std::string& trajectory_file)
    : config_(config),
      tracker_(with_history(config.estimator, config.state.history_s)),
      counters_(logger(kName)),
      odometry_(participant, transport::topics::kOdometry),
      corrected_(participant, transport::topics::kCorrected) {
  if (!trajectory_file.empty()) {
    {  // A restarted fuse-state appends after what its previous instance wrote.
      std::ifstream existing(trajectory_file);
      for (std::string line; std::getline(existing, line);) {
        if (!line.empty() && line[0] != '#') trajectory_t_ = std::max(trajectory_t_, std::atof(line.c_str()));
      }
    }
    trajectory_.open(trajectory_file, std::ios::app);
    if (!trajectory_) throw std::runtime_error("cannot open trajectory file '" + trajectory_file + "' for appending");
    trajectory_ << std::fixed << std::setprecision(9);
  }
  if (const std::string& file = config.state.checkpoint_file; !file.empty()) {
    std::string why;
    checkpoint_ = read_checkpoint(file, why);
    if (checkpoint_) {
      map_drift_ = checkpoint_->map_drift;
      map_drift_t_ = checkpoint_->posterior.t;
      logger(kName)->info("checkpoint {} holds the posterior at t={:.3f}", file, checkpoint_->posterior.t);
    } else {
      logger(kName)->info("{}", why);
    }
    checkpoint_writer_ = std::make_unique<CheckpointWriter>(file, config.state.checkpoint_period_s);
  }
  imu_sub_ = std::make_unique<transport::Subscriber<fuse_msgs::ImuSample>>(
      participant, transport::topics::kImu, [this](const fuse_msgs::ImuSample& m) { on_imu(m); },
      [this](const std::string& why) { malformed("imu", why); });
  correction_sub_ = std::make_unique<transport::Subscriber<fuse_msgs::Correction>>(
      participant, transport::topics::kCorrection, [this](const fuse_msgs::Correction& m) { on_correction(m); },
      [this](const std::string& why) { malformed("correction", why); });
  query_server_ = std::make_unique<transport::RpcServer<fuse_msgs::QueryRequest, fuse_msgs::QueryReply>>(
      participant, transport::services::kQuery,
      [this](const fuse_msgs::QueryRequest& req, fuse_msgs::QueryReply& rep) { on_query(req, rep); },
      transport::Dispatch::kInline);  // both handlers take the state lock briefly and answer
  history_server_ = std::make_unique<transport::RpcServer<fuse_msgs::HistoryRequest, fuse_msgs::HistoryReply>>(
      participant, transport::services::kHistory,
      [this](const fuse_msgs::HistoryRequest& req, fuse_msgs::HistoryReply& rep) { on_history(req, rep); },
      transport::Dispatch::kInline);
  health_ = std::make_unique<HealthReporter>(participant, kName, config.health.period_s, config.health.instance_window_s, [this] { return health(); });
  instances_ = health_.get();
  if (config.ros2.enabled) {
    ros2_ = std::make_unique<Ros2Output>(participant, config.ros2, Ros2Output::Outputs{true, false, false});
    ros2_->static_transform(config.estimator.T_imu_lidar);
    ros2_->attach(*health_);
  }
}

StateService::~StateService() {
  imu_sub_.reset();  // no IMU callback runs once health_ (declared after it) goes
}

void StateService::run() {
  // Recovery wait: the corrections held by fuse-update's writer arrive once it is discovered;
  // wait for that (and a moment for the backlog), at most state.recovery_wait_s.
  constexpr double kBacklogSettle = 0.2;  // s after matching fuse-update
  const auto start = std::chrono::steady_clock::now();
  std::optional<std::chrono::steady_clock::time_point> matched;
  while (!stop_requested()) {
    const auto now = std::chrono::steady_clock::now();
    if (!matched && correction_sub_->matched() > 0) matched = now;
    if (matched && std::chrono::duration<double>(now - *matched).count() >= kBacklogSettle) break;
    if (std::chrono::duration<double>(now - start).count() >= config_.state.recovery_wait_s) break;
    wait_for_stop_alive(0.01);
  }
  if (!stop_requested()) {
    std::lock_guard<std::mutex> lock(mutex_);
    go_live();
  }
  while (!wait_for_stop_alive(0.1)) {  // pings the service manager's watchdog
    std::lock_guard<std::mutex> lock(mutex_);
    tracking();  // status changes are logged even when nobody asks
  }
  health_->publish_now();
}

void StateService::malformed(const std::string& topic, const std::string& why) {
  std::lock_guard<std::mutex> lock(mutex_);
  counters_.count("malformed_" + topic, "malformed " + topic + " sample: " + why);
  last_error_ = "malformed " + topic + " sample: " + why;
}

void StateService::on_imu(const fuse_msgs::ImuSample& msg) {
  std::optional<fuse_msgs::StateEstimate> odometry;
  // Two fuse-ingest alive under this system name (another system on the domain with the same
  // name, or one started twice): their IMU streams are not mixed; none is used until one is left.
  const HealthReporter* instances = instances_.load();
  const std::string twice = instances != nullptr ? instances->duplicate("fuse-ingest") : std::string();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!twice.empty()) {
      counters_.count("imu_refused_two_ingests", "IMU sample refused: " + twice);
      last_error_ = twice;
      return;
    }
    ImuSample imu;
    try {
      imu = from_msg(msg);
    } catch (const InvalidSample& e) {
      counters_.count(e.reason(), std::string("IMU sample refused: ") + e.what());
      last_error_ = e.what();
      return;
    }
    if (!imu_buffer_.empty() && imu.t <= imu_buffer_.back().t) {
      // Re-delivered history (a late-joined transient-local backlog) or out of order: the
      // tracker refuses and counts it as well; keep the buffer sorted.
      if (live_) odometry = feed(imu);
      return;
    }
    imu_buffer_.push_back(imu);
    host_clock_.observe_now(tracker_.state_time(imu.t));  // the sensor clock queries use: the state's
    while (imu_buffer_.size() > 2 && imu_buffer_.back().t - imu_buffer_.front().t > config_.state.imu_buffer_s) {
      imu_buffer_.pop_front();
    }
    if (live_) odometry = feed(imu);
  }
  if (odometry) {
    odometry_.publish(*odometry);
    if (ros2_) {
      try {
        ros2_->odometry(*odometry);
      } catch (const std::exception& e) {
        std::lock_guard<std::mutex> lock(mutex_);
        counters_.count("ros2_not_published", std::string("odometry not published for ROS 2: ") + e.what());
      }
    }
  }
}

bool StateService::catching_up() const {
  const StateHistory& h = tracker_.history();
  return tracker_.initialised() && h.newest_time() - h.fresh_time() > kCatchUpS;
}

std::optional<fuse_msgs::StateEstimate> StateService::feed(const ImuSample& imu) {
  if (tracker_.initialised() && tracker_.state_time(imu.t) <= live_since_t_) {
    // Held IMU from before the restored posterior, arriving after it (a writer's history is
    // delivered over a second or so after a restart): history, not a fault of the stream.
    counters_.add("imu_before_restore");
    return std::nullopt;
  }
  const bool was_initialised = tracker_.initialised();
  last_imu_arrival_ = std::chrono::steady_clock::now();
  imu_since_restore_ = true;
  tracker_.ingest(imu);
  take_tracker_events();
  if (!tracker_.initialised()) return std::nullopt;
  if (!was_initialised) live_since_t_ = tracker_.history().oldest_time();  // static initialisation
  if (catching_up()) {
    // The newest state is not up to date while held scans' corrections are applied far behind
    // it: computing it for every sample would re-propagate the whole tail each time.
    counters_.add("odometry_deferred_catching_up");
    return std::nullopt;
  }
  fuse_msgs::StateEstimate e = estimate(tracker_.history().query(tracker_.history().newest_time()), ++odometry_sequence_);
  mark(tracking(), e);
  return e;
}

fuse_msgs::StateEstimate StateService::estimate(const StateQuery& q, std::uint64_t sequence) const {
  fuse_msgs::StateEstimate e = to_estimate(q, sequence);
  e.map_frame(frame_.state);
  e.localization_candidates(frame_.relocalizing() ? candidates_ : 0);
  if (const std::optional<HostClockOffsets> o = host_clock_.offsets_now()) {
    e.host_clock_known(true);
    e.host_realtime_offset(o->realtime);
    e.host_monotonic_offset(o->monotonic);
  }
  if (!q.ok()) return e;
  // Position in the world frame as it is; the rotation block is a body-frame perturbation.
  PoseCovariance add = map_drift_;
  add.bottomRightCorner<3, 3>() = q.x.R.transpose() * map_drift_.bottomRightCorner<3, 3>() * q.x.R;
  add.topRightCorner<3, 3>().setZero();
  add.bottomLeftCorner<3, 3>().setZero();
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) e.pose_covariance()[static_cast<std::size_t>(r * 6 + c)] += add(r, c);
  }
  return e;
}

void StateService::count_map_drift(const fuse_msgs::Correction& msg) {
  if (msg.t() <= map_drift_t_) return;  // counted before (a re-delivered correction, the checkpoint)
  PoseCovariance d;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) d(r, c) = msg.map_drift()[static_cast<std::size_t>(r * 6 + c)];
  }
  if (!d.allFinite() || d.diagonal().minCoeff() < 0.0) {
    counters_.count("map_drift_invalid", "correction at t=" + std::to_string(msg.t()) + ": map drift not a covariance, ignored");
    return;
  }
  map_drift_ += d;
  map_drift_t_ = msg.t();
}

void StateService::take_tracker_events() {
  for (const StateTracker::Event& e : tracker_.take_events()) {
    if (e.kind == TrackingEvent::kRestart) continue;  // restore_from says so itself
    unconfirmed_ = true;
    unconfirmed_why_ = std::string(to_string(e.kind)) + " at t=" + fmt::format("{:.3f}", e.t) +
                       ": the prior is uncertain until a scan is re-localised";
  }
}

void StateService::go_live() {
  if (live_) return;
  live_ = true;
  // The newest posterior held anywhere: fuse-update's corrections or our own checkpoint.
  std::optional<Posterior> best = pending_recovery_;
  std::optional<WorldFrame> frame = pending_frame_;
  std::string source = "the correction";
  if (checkpoint_ && (!best || checkpoint_->posterior.t > best->t)) {
    best = checkpoint_->posterior;
    frame = checkpoint_->frame;
    source = "the checkpoint";
  }
  pending_recovery_.reset();
  pending_frame_.reset();
  if (frame) frame_ = *frame;
  checkpoint_.reset();
  if (best) {
    restore_from(*best, source);
    // fuse-update skips the held scans at or before what is restored (state/corrected).
    corrected_.publish(estimate(tracker_.history().query(best->t), best->scan_sequence));
    return;
  }
  logger(kName)->info("no correction to recover from: initialising from the IMU ({} buffered samples)",
                      imu_buffer_.size());
  for (const ImuSample& imu : imu_buffer_) tracker_.ingest(imu);
  if (tracker_.initialised()) live_since_t_ = tracker_.history().oldest_time();
}

void StateService::restore_from(const Posterior& post, const std::string& source) {
  // The held measurement at t is the last IMU sample at or before t.
  // Buffered stamps are on the IMU's clock: t_imu − t_d on the state's.
  const double td = post.x.td;
  std::optional<ImuSample> held;
  for (const ImuSample& imu : imu_buffer_) {
    if (imu.t - td > post.t) break;
    held = imu;
    held->t = post.t;
  }
  if (!held) {
    counters_.count("recovery_without_imu",
                    "no buffered IMU before the recovered posterior: coasting from it at rest in its attitude");
  }
  tracker_.restore(post.t, post.x, post.P, held);
  std::size_t replayed = 0;
  double first_after = -1.0;
  for (const ImuSample& imu : imu_buffer_) {
    if (imu.t - td <= post.t) continue;
    if (first_after < 0.0) first_after = imu.t - td;
    tracker_.ingest(imu);
    ++replayed;
  }
  last_applied_correction_t_ = post.t;
  live_since_t_ = post.t;
  restored_at_ = std::chrono::steady_clock::now();
  imu_since_restore_ = replayed > 0;
  unconfirmed_ = true;
  unconfirmed_why_ = "restored after a restart: waiting for a scan to confirm the posterior";
  counters_.add("recoveries");
  if (replayed == 0) {
    logger(kName)->info("recovered from {} at t={:.3f}; no buffered IMU after it yet (the held IMU is still "
                        "arriving, or none was held); relocalizing until a scan confirms it",
                        source, post.t);
  } else {
    logger(kName)->info(
        "recovered from {} at t={:.3f}; re-propagated {} buffered IMU samples up to t={:.3f} ({:.2f} s{}); "
        "relocalizing until a scan confirms it",
        source, post.t, replayed, imu_buffer_.back().t - td, imu_buffer_.back().t - td - post.t,
        first_after > post.t + config_.estimator.divergence.max_imu_gap
            ? fmt::format(", of which a {:.2f} s data gap coasted", first_after - post.t)
            : "");
  }
  if (source == "the checkpoint") counters_.add("recoveries_from_checkpoint");
}

void StateService::on_correction(const fuse_msgs::Correction& msg) {
  if (msg.result() == fuse_msgs::SCAN_SKIPPED) return;
  std::optional<fuse_msgs::StateEstimate> corrected;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (std::isfinite(msg.t())) newest_correction_t_ = std::max(newest_correction_t_, msg.t());
    Posterior post;
    WorldFrame frame;
    try {
      post = from_msg(msg);
      frame = frame_of(msg);
    } catch (const InvalidSample& e) {
      counters_.count(e.reason(), std::string("correction refused: ") + e.what());
      last_error_ = e.what();
      return;
    }
    if (!live_ || !tracker_.initialised()) {
      // During the recovery wait (or before anything else): keep the newest to restore from.
      if (msg.result() == fuse_msgs::SCAN_UPDATED && (!pending_recovery_ || post.t > pending_recovery_->t)) {
        pending_recovery_ = post;
        pending_frame_ = frame;
      }
      if (live_ && pending_recovery_) {
        if (pending_frame_) frame_ = *pending_frame_;
        restore_from(*pending_recovery_, "the correction");
        pending_recovery_.reset();
        pending_frame_.reset();
      } else {
        return;
      }
    } else {
      if (!take_frame(msg, frame)) return;
      StateHistory& h = tracker_.history();
      if (msg.result() == fuse_msgs::SCAN_UPDATED && post.t != last_applied_correction_t_) {
        if (!h.ensure_entry(post.t)) {
          counters_.count("correction_too_old", "correction at t=" + std::to_string(post.t) + " is older than the history");
          return;
        }
        h.correct(post.t, post.x, post.P);
        last_applied_correction_t_ = post.t;
        counters_.add("corrections_applied");
        count_map_drift(msg);
        if (checkpoint_writer_) checkpoint_writer_->offer(Checkpoint{post, map_drift_, frame_});
        if (unconfirmed_ && msg.tracking() == fuse_msgs::TRACKING_OK) unconfirmed_ = false;
      } else if (msg.result() == fuse_msgs::SCAN_PRIOR_ONLY) {
        counters_.count("corrections_prior_only", fmt::format("the scan ending at t={:.6f} gave fuse-update no update: "
                                                              "propagating without a correction",
                                                              post.t));
      }
    }
    update_tracking_ = msg.tracking();
    const StateQuery q = tracker_.history().query(post.t);
    if (!q.ok()) return;
    write_pose(q.t, q.x);
    corrected = estimate(q, msg.scan_sequence());
    corrected->status(fuse_msgs::STATUS_CORRECTED);
  }
  corrected_.publish(*corrected);
}

bool StateService::take_frame(const fuse_msgs::Correction& msg, const WorldFrame& frame) {
  if (frame.epoch < frame_.epoch) {
    counters_.add("corrections_of_an_older_frame");  // sent before a frame change this history has made
    return false;
  }
  if (frame.epoch > frame_.epoch) {
    Eigen::Isometry3d T;
    try {
      T = frame_change_of(msg);
    } catch (const InvalidSample& e) {
      counters_.count(e.reason(), std::string("correction refused: ") + e.what());
      return false;
    }
    if (frame.epoch != frame_.epoch + 1) {
      counters_.count("frame_epochs_skipped", fmt::format("correction of world frame epoch {} after epoch {}: "
                                                          "taking its frame change alone",
                                                          frame.epoch, frame_.epoch));
    }
    tracker_.history().transform_world(T);
    for (auto& held : held_poses_) held.second = T * held.second;
    const double moved = T.translation().norm();
    const double turned = Eigen::AngleAxisd(T.linear()).angle() * 180.0 / M_PI;
    logger(kName)->info("world frame {} -> {} (epoch {}){}", to_string(frame_.state), to_string(frame.state), frame.epoch,
                        moved > 0.0 || turned > 0.0 ? fmt::format(": history moved {:.2f} m, turned {:.1f} deg", moved, turned)
                                                    : std::string());
    counters_.add("world_frame_changes");
    frame_ = frame;
  }
  candidates_ = msg.localization_candidates();
  localization_ = msg.localization();
  return true;
}

void StateService::write_pose(double t, const NavState& x) {
  if (!trajectory_.is_open()) return;
  const Eigen::Isometry3d T = x.T_WI();
  constexpr std::size_t kMaxHeld = 1000000;  // ~28 h of scans at 10 Hz
  if (frame_.relocalizing() && held_poses_.size() < kMaxHeld) {
    if (held_poses_.empty() || t > held_poses_.back().first) held_poses_.emplace_back(t, T);
    return;
  }
  if (frame_.relocalizing()) counters_.add("trajectory_poses_not_held");
  held_poses_.emplace_back(t, T);  // written in the map frame now, after those held before
  for (const auto& [ht, pose] : held_poses_) {
    if (ht <= trajectory_t_) continue;
    trajectory_t_ = ht;
    const Eigen::Quaterniond r(pose.linear());
    trajectory_ << ht << ' ' << pose.translation().x() << ' ' << pose.translation().y() << ' ' << pose.translation().z()
                << ' ' << r.x() << ' ' << r.y() << ' ' << r.z() << ' ' << r.w() << '\n';
  }
  held_poses_.clear();
  trajectory_.flush();
}

Tracking StateService::tracking() {
  Tracking now = Tracking::kTracking;
  std::string why;
  if (!live_) {
    now = Tracking::kRelocalizing;
    why = "starting: waiting for a posterior from fuse-update or the checkpoint before going live";
  } else if (!tracker_.initialised()) {
    if (tracker_.counters().get("init_not_at_rest") > 0) {
      now = Tracking::kLost;
      why = "no posterior to recover from and the sensor moves: waiting for it to rest";
    }
  } else {
    const StateHistory& h = tracker_.history();
    const double since = std::max(last_applied_correction_t_, live_since_t_);
    if (update_tracking_ == fuse_msgs::TRACKING_LOST) {
      now = Tracking::kLost;
      why = "fuse-update reports that the scans do not fit the map";
    } else if (h.newest_time() - since > config_.state.lost_after_s) {
      now = Tracking::kLost;
      why = fmt::format("no LiDAR correction for {:.1f} s of IMU (state.lost_after_s)", h.newest_time() - since);
    } else if (frame_.relocalizing()) {
      now = Tracking::kRelocalizing;
      why = fmt::format("{} the saved map for this session's place: {}",
                        frame_.state == fuse_msgs::MAP_FRAME_SEARCHING ? "searching" : "confirming a location in",
                        localization_.empty() ? to_string(frame_.state) : localization_);
    } else if (catching_up()) {
      now = Tracking::kRelocalizing;
      why = fmt::format("catching up on held scans ({:.1f} s behind the newest IMU)", h.newest_time() - h.fresh_time());
    } else if (unconfirmed_) {
      now = Tracking::kRelocalizing;
      why = unconfirmed_why_;
    } else if (update_tracking_ == fuse_msgs::TRACKING_RELOCALIZING) {
      now = Tracking::kRelocalizing;
      why = "fuse-update re-localises scans against the map (the prior is uncertain)";
    }
  }
  if (now != tracking_) {
    auto log = logger(kName);
    if (now == Tracking::kTracking) {
      log->info("tracking{} (was {})", live_ ? " again" : "", to_string(tracking_));
    } else if (!live_) {
      log->info("{}: {}", to_string(now), why);  // every start, not an episode
    } else {
      log->warn("{}: {}", to_string(now), why);
    }
    if (now == Tracking::kLost) counters_.add("lost_episodes");
    if (now == Tracking::kRelocalizing && live_) counters_.add("relocalizing_episodes");
    tracking_ = now;
  }
  tracking_reason_ = why;
  return now;
}

void StateService::on_query(const fuse_msgs::QueryRequest& req, fuse_msgs::QueryReply& rep) {
  std::lock_guard<std::mutex> lock(mutex_);
  counters_.add("queries");
  const bool have_state = tracker_.initialised();
  const Tracking status = tracking();
  double t = req.t();
  if (!req.latest() && req.clock() != fuse_msgs::CLOCK_SENSOR) {
    if (req.clock() != fuse_msgs::CLOCK_HOST_REALTIME && req.clock() != fuse_msgs::CLOCK_HOST_MONOTONIC) {
      counters_.add("query_bad_request");
      set_error(fuse_msgs::RPC_BAD_REQUEST, "unknown query clock " + std::to_string(static_cast<int>(req.clock())), rep);
      return;
    }
    const std::optional<HostClockOffsets> o = host_clock_.offsets_now();
    if (!o) {
      set_error(fuse_msgs::RPC_NOT_READY, "no host clock mapping yet: no IMU sample has arrived", rep);
      return;
    }
    t -= req.clock() == fuse_msgs::CLOCK_HOST_REALTIME ? o->realtime : o->monotonic;  // t_sensor = t_host − offset
  }
  if (req.latest()) {
    if (!have_state) {
      rep.estimate().status(status == Tracking::kLost ? fuse_msgs::STATUS_LOST : fuse_msgs::STATUS_NOT_INITIALISED);
      return;
    }
    // While catching up, the newest up-to-date state (computing the newest would re-propagate the tail).
    t = catching_up() ? tracker_.history().fresh_time() : tracker_.history().newest_time();
  }
  if (!std::isfinite(t) || t < 0.0 || t > kMaxQueryTime) {
    counters_.add("query_bad_request");
    set_error(fuse_msgs::RPC_BAD_REQUEST, "query time must be finite, non-negative and below 1e10 s", rep);
    return;
  }
  if (have_state && std::abs(t - tracker_.history().newest_time()) > kAbsurdTimeSpan) {
    counters_.add("query_bad_request");
    set_error(fuse_msgs::RPC_BAD_REQUEST, "query time is more than a day away from the newest state", rep);
    return;
  }
  StateQuery q = tracker_.history().query(t);
  if (!have_state) q.status = QueryStatus::kNotInitialised;
  rep.estimate(estimate(q, 0));
  mark(status, rep.estimate());
  // The answer is the estimate with its status; the message says why it is not one to steer by
  // (the client turns these statuses into errors).
  if (q.status == QueryStatus::kTooOld || q.status == QueryStatus::kInFuture) {
    counters_.add("query_out_of_range");
    rep.error_message(fmt::format("t={:.6f} is {} the history [{:.6f}, {:.6f}] (sensor clock)", t,
                                  q.status == QueryStatus::kTooOld ? "before" : "after",
                                  tracker_.history().oldest_time(), tracker_.history().newest_time()));
  } else if (status != Tracking::kTracking) {
    rep.error_message(fmt::format("the estimator is {}: {}", to_string(status), tracking_reason_).substr(0, 255));
  }
}

void StateService::on_history(const fuse_msgs::HistoryRequest& req, fuse_msgs::HistoryReply& rep) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double t0 = req.t_start(), t1 = req.t_end();
  if (!std::isfinite(t0) || !std::isfinite(t1) || t1 < t0 || t1 - t0 > kMaxHistorySpan) {
    counters_.add("history_bad_request");
    set_error(fuse_msgs::RPC_BAD_REQUEST, "history span must be finite, ordered and at most 1 s", rep);
    return;
  }
  if (!live_) {  // recovering: the caller holds the scan and asks again
    rep.initialised(true);
    rep.recovering(true);
    set_error(fuse_msgs::RPC_NOT_READY, "recovering the last correction", rep);
    return;
  }
  if (!tracker_.initialised()) {
    // The sample that completes the still window may be just behind a scan that ends before it
    // (a ROS 2 cloud ends at its last point, microseconds before the frame's IMU sample): while
    // the IMU flows and has not reached the scan's end, the requester waits; otherwise the scan
    // cannot be covered and is skipped.
    const double silent =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - last_imu_arrival_).count();
    const bool imu_behind = tracker_.last_imu_time() < t1 && silent < kImuSilenceS;
    rep.initialised(imu_behind);
    set_error(fuse_msgs::RPC_NOT_READY,
              imu_behind ? "the state is not initialised yet: waiting for the IMU at the scan end"
                         : "the state is not initialised",
              rep);
    return;
  }
  rep.initialised(true);
  StateHistory& h = tracker_.history();
  if (h.newest_time() < t1) {
    // Beyond the allowed jump of a clock: the scan's stamp is wrong (or only the LiDAR clock has
    // stepped so far); refused at once instead of holding fuse-update until its deadline.
    const double ahead = t1 - tracker_.last_imu_time();
    if (ahead > config_.estimator.clock.max_gap_s) {
      counters_.count("history_ahead_of_imu", fmt::format("scan ending at t={:.3f} is {:.3f} s ahead of the IMU "
                                                          "(more than estimator.clock.max_gap_s): refused",
                                                          t1, ahead));
      set_error(fuse_msgs::RPC_BAD_REQUEST, "scan end is far ahead of the IMU clock", rep);
      return;
    }
    // Samples merely in flight (a scan overtaking its IMU on the wire) are waited for: the IMU
    // must have been silent for kImuSilenceS of wall clock, counted from the newest sample and
    // from the first request for this scan (a lockstep replay publishes the IMU after a dropout
    // in a burst just before the scan, after a long silence). Then the scan is taken as fuse-run
    // takes it: beyond divergence.max_imu_gap the state coasts to its end as across a data gap
    // and the scan is re-localised; closer, ensure_entry below extrapolates with the held
    // measurement.
    const auto now = std::chrono::steady_clock::now();
    if (t1 != silent_wait_t_) {
      silent_wait_t_ = t1;
      silent_wait_since_ = now;
    }
    double silent = std::chrono::duration<double>(now - std::max(last_imu_arrival_, silent_wait_since_)).count();
    double needed = kImuSilenceS;
    if (!imu_since_restore_) {  // the samples held during the restart are still to come
      silent = std::min(silent, std::chrono::duration<double>(now - restored_at_).count());
      needed = kRestartImuWaitS;
    }
    if (silent < needed) {
      set_error(fuse_msgs::RPC_NOT_READY, "IMU does not cover the scan end yet", rep);
      return;
    }
    // Coasting starts from the newest entry: the requester's previous posterior must be in it,
    // or the coast (its held specific force cancels gravity at the state it starts from) would
    // start from the uncorrected state, which the requester cannot patch afterwards.
    if (req.after_correction() > newest_correction_t_ + 1e-9) {
      set_error(fuse_msgs::RPC_NOT_READY, "waiting for the requester's previous correction", rep);
      return;
    }
    if (ahead > config_.estimator.divergence.max_imu_gap && config_.estimator.divergence.coast_silent_imu &&
        tracker_.coast_to(t1)) {
      counters_.count("history_coasted", fmt::format("the IMU is silent at the scan ending at t={:.3f} ({:.3f} s "
                                                     "after the newest sample): coasted to it",
                                                     t1, ahead));
      logger(kName)->debug("history request for t={:.6f}: IMU silent {:.3f} s, coasted", t1, silent);
      take_tracker_events();
      if (!unconfirmed_) {
        unconfirmed_ = true;
        unconfirmed_why_ = "the IMU is silent: coasting, scans re-localised";
      }
    }
  }
  if (!h.ensure_entry(t1)) {
    counters_.add("history_too_old");
    set_error(fuse_msgs::RPC_BAD_REQUEST, "scan end is older than the state history", rep);
    return;
  }
  // From the entry at or before t_start (interpolation of the first point) to the one at t_end.
  const auto before = h.entries_between(h.oldest_time(), t0);
  const double from = before.empty() ? h.oldest_time() : before.back()->t;
  const auto slice = h.entries_between(from, t1);
  if (slice.size() > 8192) {
    set_error(fuse_msgs::RPC_BAD_REQUEST, "history slice has too many entries", rep);
    return;
  }
  for (const StateHistory::Entry* e : slice) rep.entries().push_back(to_msg(*e));
  const StateQuery q_end = h.query(t1);
  for (int r = 0; r < kStateDim; ++r) {
    for (int c = 0; c < kStateDim; ++c) rep.covariance()[static_cast<std::size_t>(r * kStateDim + c)] = q_end.P(r, c);
  }
  rep.last_correction_time(h.last_correction_time());
  rep.map_frame(frame_.state);
  rep.frame_epoch(frame_.epoch);
  counters_.add("history_served");
}

HealthSnapshot StateService::health() {
  std::lock_guard<std::mutex> lock(mutex_);
  HealthSnapshot s;
  const Tracking t = tracking();
  if (!live_) {
    s.state = "starting";
  } else if (t != Tracking::kTracking) {
    s.state = to_string(t);  // relocalizing | lost
  } else {
    s.state = tracker_.initialised() ? "running" : "initialising";
  }
  s.counters = counters_.map();
  for (const auto& [k, v] : tracker_.counters().map()) s.counters[k] += v;
  s.counters["imu_malformed"] = imu_sub_ ? imu_sub_->malformed() : 0;
  if (checkpoint_writer_) {
    s.counters["checkpoints_written"] = checkpoint_writer_->written();
    s.counters["checkpoint_failures"] = checkpoint_writer_->failures();
  }
  s.last_error = t != Tracking::kTracking && !tracking_reason_.empty() ? to_string(t) + std::string(": ") + tracking_reason_
                                                                      : last_error_;
  return s;
}

}  // namespace fuse::service

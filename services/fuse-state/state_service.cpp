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

void set_error(fuse_msgs::RpcStatus status, const std::string& message, fuse_msgs::QueryReply& rep) {
  rep.error(status);
  rep.error_message(message.substr(0, 255));
}
void set_error(fuse_msgs::RpcStatus status, const std::string& message, fuse_msgs::HistoryReply& rep) {
  rep.error(status);
  rep.error_message(message.substr(0, 255));
}
}  // namespace

StateService::StateService(const SystemConfig& config, transport::Participant& participant,
                           const std::string& trajectory_file)
    : config_(config),
      tracker_(config.estimator),
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
  health_ = std::make_unique<HealthReporter>(participant, kName, config.health.period_s, [this] { return health(); });
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
  {
    std::lock_guard<std::mutex> lock(mutex_);
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
    while (imu_buffer_.size() > 2 && imu_buffer_.back().t - imu_buffer_.front().t > config_.state.imu_buffer_s) {
      imu_buffer_.pop_front();
    }
    if (live_) odometry = feed(imu);
  }
  if (odometry) odometry_.publish(*odometry);
}

std::optional<fuse_msgs::StateEstimate> StateService::feed(const ImuSample& imu) {
  tracker_.ingest(imu);
  if (!tracker_.initialised()) return std::nullopt;
  return to_estimate(tracker_.history().query(tracker_.history().newest().t), ++odometry_sequence_);
}

void StateService::go_live() {
  if (live_) return;
  live_ = true;
  if (pending_recovery_) {
    restore_from(*pending_recovery_);
    pending_recovery_.reset();
    return;
  }
  logger(kName)->info("no correction to recover from: initialising from the IMU ({} buffered samples)",
                      imu_buffer_.size());
  for (const ImuSample& imu : imu_buffer_) tracker_.ingest(imu);
}

void StateService::restore_from(const Posterior& post) {
  // The held measurement at t is the last IMU sample at or before t.
  ImuSample held;
  held.t = post.t;
  bool have_held = false;
  for (const ImuSample& imu : imu_buffer_) {
    if (imu.t > post.t) break;
    held.gyro = imu.gyro;
    held.accel = imu.accel;
    have_held = true;
  }
  if (!have_held) {
    counters_.count("recovery_without_imu", "no buffered IMU before the recovered correction: holding zero rates");
    held.gyro.setZero();
    held.accel = -post.x.R.transpose() * post.x.g;
  }
  tracker_.restore(post.t, post.x, post.P, held);
  std::size_t replayed = 0;
  for (const ImuSample& imu : imu_buffer_) {
    if (imu.t <= post.t) continue;
    tracker_.ingest(imu);
    ++replayed;
  }
  last_applied_correction_t_ = post.t;
  counters_.add("recoveries");
  logger(kName)->info("recovered from the correction at t={:.3f}; re-propagated {} buffered IMU samples", post.t, replayed);
}

void StateService::on_correction(const fuse_msgs::Correction& msg) {
  if (msg.result() == fuse_msgs::SCAN_SKIPPED) return;
  std::optional<fuse_msgs::StateEstimate> corrected;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    Posterior post;
    try {
      post = from_msg(msg);
    } catch (const InvalidSample& e) {
      counters_.count(e.reason(), std::string("correction refused: ") + e.what());
      last_error_ = e.what();
      return;
    }
    if (!live_ || !tracker_.initialised()) {
      // During the recovery wait (or before anything else): keep the newest to restore from.
      if (msg.result() == fuse_msgs::SCAN_UPDATED && (!pending_recovery_ || post.t > pending_recovery_->t)) {
        pending_recovery_ = post;
      }
      if (live_ && pending_recovery_) {
        restore_from(*pending_recovery_);
        pending_recovery_.reset();
      } else {
        return;
      }
    } else {
      StateHistory& h = tracker_.history();
      if (msg.result() == fuse_msgs::SCAN_UPDATED && post.t != last_applied_correction_t_) {
        if (!h.ensure_entry(post.t)) {
          counters_.count("correction_too_old", "correction at t=" + std::to_string(post.t) + " is older than the history");
          return;
        }
        h.correct(post.t, post.x, post.P);
        last_applied_correction_t_ = post.t;
        counters_.add("corrections_applied");
      }
    }
    const StateQuery q = tracker_.history().query(post.t);
    if (!q.ok()) return;
    if (trajectory_.is_open() && q.t > trajectory_t_) {
      trajectory_t_ = q.t;
      const Eigen::Quaterniond r(q.x.R);
      trajectory_ << q.t << ' ' << q.x.p.x() << ' ' << q.x.p.y() << ' ' << q.x.p.z() << ' ' << r.x() << ' ' << r.y() << ' '
                  << r.z() << ' ' << r.w() << '\n';
      trajectory_.flush();
    }
    corrected = to_estimate(q, msg.scan_sequence());
    corrected->status(fuse_msgs::STATUS_CORRECTED);
  }
  corrected_.publish(*corrected);
}

void StateService::on_query(const fuse_msgs::QueryRequest& req, fuse_msgs::QueryReply& rep) {
  std::lock_guard<std::mutex> lock(mutex_);
  counters_.add("queries");
  const bool have_state = tracker_.initialised();
  double t = req.t();
  if (req.latest()) {
    if (!have_state) {
      rep.estimate().status(fuse_msgs::STATUS_NOT_INITIALISED);
      return;
    }
    t = tracker_.history().newest().t;
  }
  if (!std::isfinite(t) || t < 0.0 || t > kMaxQueryTime) {
    counters_.add("query_bad_request");
    set_error(fuse_msgs::RPC_BAD_REQUEST, "query time must be finite, non-negative and below 1e10 s", rep);
    return;
  }
  if (have_state && std::abs(t - tracker_.history().newest().t) > kAbsurdTimeSpan) {
    counters_.add("query_bad_request");
    set_error(fuse_msgs::RPC_BAD_REQUEST, "query time is more than a day away from the newest state", rep);
    return;
  }
  StateQuery q = tracker_.history().query(t);
  if (!have_state) q.status = QueryStatus::kNotInitialised;
  rep.estimate(to_estimate(q, 0));
}

void StateService::on_history(const fuse_msgs::HistoryRequest& req, fuse_msgs::HistoryReply& rep) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double t0 = req.t_start(), t1 = req.t_end();
  if (!std::isfinite(t0) || !std::isfinite(t1) || t1 < t0 || t1 - t0 > kMaxHistorySpan) {
    counters_.add("history_bad_request");
    set_error(fuse_msgs::RPC_BAD_REQUEST, "history span must be finite, ordered and at most 1 s", rep);
    return;
  }
  if (!live_) {  // recovering: the caller should retry, as for IMU not covering the scan yet
    rep.initialised(true);
    set_error(fuse_msgs::RPC_NOT_READY, "recovering the last correction", rep);
    return;
  }
  rep.initialised(tracker_.initialised());
  if (!rep.initialised()) {
    set_error(fuse_msgs::RPC_NOT_READY, "the state is not initialised", rep);
    return;
  }
  StateHistory& h = tracker_.history();
  if (h.newest().t < t1) {
    set_error(fuse_msgs::RPC_NOT_READY, "IMU does not cover the scan end yet", rep);
    return;
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
  counters_.add("history_served");
}

HealthSnapshot StateService::health() {
  std::lock_guard<std::mutex> lock(mutex_);
  HealthSnapshot s;
  s.state = !live_ ? "starting" : (tracker_.initialised() ? "running" : "initialising");
  s.counters = counters_.map();
  for (const auto& [k, v] : tracker_.counters().map()) s.counters[k] += v;
  s.counters["imu_malformed"] = imu_sub_ ? imu_sub_->malformed() : 0;
  s.last_error = last_error_;
  return s;
}

}  // namespace fuse::service

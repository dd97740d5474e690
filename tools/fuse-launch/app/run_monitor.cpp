#include "run_monitor.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "fuse/core/logging.hpp"
#include "fuse/map/map_server_core.hpp"

namespace fuse::launch_tool {

namespace {
/// Data flows while fuse-ingest's scan count rose within this many health periods.
constexpr double kFlowPeriods = 3.0;
constexpr double kFlowMinS = 1.0;

/// Counters worth a line in the summary, per service (the rest are in the services' logs).
const std::map<std::string, std::vector<std::string>>& summary_counters() {
  static const std::map<std::string, std::vector<std::string>> c = {
      {"fuse-ingest", {"scans_published", "imu_published", "events_skipped"}},
      {"fuse-state",
       {"recoveries", "recoveries_from_checkpoint", "imu_gap", "relocalizing_episodes", "lost_episodes",
        "correction_too_old", "odometry_deferred_catching_up"}},
      {"fuse-update",
       {"scans_processed", "scan_before_init", "scans_already_corrected", "scans_older_than_state", "scans_dropped_backlog",
        "history_wait_timeout", "history_refused", "recovery_scans", "recovery_ambiguous", "diverged", "observations_resent",
        "observations_given_up", "moving_points_screened"}},
      {"fuse-map", {"map_observations_applied", "journal_errors", "pending_dropped", "pending_observations"}},
      {"fuse-viz", {"connections", "messages_sent", "messages_dropped_slow_client", "client_stalls", "client_requests_bad"}},
  };
  return c;
}

std::size_t line_count(const std::string& path) {
  std::ifstream f(path);
  std::size_t n = 0;
  for (std::string line; std::getline(f, line);) n += (!line.empty() && line[0] != '#') ? 1 : 0;
  return n;
}
}  // namespace

RunMonitor::RunMonitor(const service::SystemConfig& config, std::string trajectory_file, std::string map_dir,
                       std::optional<std::uint64_t> replay_events, MonitorLimits limits)
    : limits_(limits),
      trajectory_file_(std::move(trajectory_file)),
      map_dir_(std::move(map_dir)),
      health_period_s_(config.health.period_s),
      watch_(config.health.instance_window_s),
      replay_events_(replay_events) {
  participant_ = transport::make_participant(config.transport, "fuse-launch");
  health_ = std::make_unique<transport::Subscriber<fuse_msgs::Health>>(
      *participant_, transport::topics::kHealth, [this](const fuse_msgs::Health& h) { on_health(h); });
  corrected_ = std::make_unique<transport::Subscriber<fuse_msgs::StateEstimate>>(
      *participant_, transport::topics::kCorrected, [this](const fuse_msgs::StateEstimate&) {
        std::lock_guard<std::mutex> lock(mutex_);
        have_estimate_ = true;
        last_estimate_ = Clock::now();
        ++poses_;
      });
  // Scans skipped before the first one processed are the static initialisation's, not losses. The
  // corrections come in order from fuse-update, so this count is exact (a health snapshot of
  // scan_before_init could be older than the first estimate).
  corrections_ = std::make_unique<transport::Subscriber<fuse_msgs::Correction>>(
      *participant_, transport::topics::kCorrection, [this](const fuse_msgs::Correction& c) {
        std::lock_guard<std::mutex> lock(mutex_);
        ++scans_answered_;
        if (std::isfinite(c.t())) newest_scan_t_ = std::max(newest_scan_t_, c.t());  // skipped scans too
        if (c.result() != fuse_msgs::SCAN_SKIPPED) {
          first_scan_processed_ = true;
        } else if (!first_scan_processed_) {
          ++skipped_before_first_estimate_;
        }
      });
  status_ = std::make_unique<transport::Subscriber<fuse_msgs::MapStatus>>(
      *participant_, transport::topics::kMapStatus, [this](const fuse_msgs::MapStatus& s) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (s.session() != 0) acked_[s.session()] = std::max(acked_[s.session()], s.acked_sequence());
        for (const fuse_msgs::SessionAck& a : s.sessions()) {
          if (a.session() != 0) acked_[a.session()] = std::max(acked_[a.session()], a.acked_sequence());
        }
      });
}

RunMonitor::~RunMonitor() {
  status_.reset();
  corrections_.reset();
  corrected_.reset();
  health_.reset();
}

void RunMonitor::on_health(const fuse_msgs::Health& h) {
  std::lock_guard<std::mutex> lock(mutex_);
  watch_.heard(h.service().to_string(), h.instance(), Clock::now());
  Instance& i = instances_[h.instance()];
  i.service = h.service().to_string();
  i.state = h.state().to_string();
  i.last_error = h.last_error().to_string();
  for (const auto& c : h.counters()) i.counters[c.name().to_string()] = c.value();
  if (i.service == "fuse-state") state_tracking_ = i.state;
  const std::uint64_t published = total("fuse-ingest", "scans_published");
  if (published > scans_published_seen_) {
    scans_published_seen_ = published;
    last_scan_published_ = Clock::now();
  }
}

std::uint64_t RunMonitor::total(const std::string& service, const std::string& counter) const {
  std::uint64_t n = 0;
  for (const auto& [id, i] : instances_) {
    if (i.service != service) continue;
    const auto it = i.counters.find(counter);
    if (it != i.counters.end()) n += it->second;
  }
  return n;
}

bool RunMonitor::data_flows(Clock::time_point now) const {
  const double window = std::max(kFlowMinS, kFlowPeriods * health_period_s_);
  return scans_published_seen_ > 0 && std::chrono::duration<double>(now - last_scan_published_).count() <= window;
}

void RunMonitor::update_progress() {
  launch::ReplaySnapshot s;
  const std::uint64_t published = total("fuse-ingest", "scans_published");
  s.events = published + total("fuse-ingest", "imu_published");
  // Both count scans replayed from below: fuse-ingest's counter comes with its heartbeat (up to a
  // health period old), the corrections as fuse-update answers (none while it is down).
  s.scans = std::max(published, scans_answered_);
  // Started at the first sample, not with the services: the rate against real time and the time
  // left then leave out the start-up (discovery, fuse-ingest waiting for the pipeline).
  if (!progress_ && s.events == 0 && newest_scan_t_ < 0.0) return;
  if (!progress_) progress_.emplace(replay_events_);
  s.poses = poses_;
  s.sensor_t = newest_scan_t_;
  s.tracking = state_tracking_;
  progress_->update(s);
}

std::string RunMonitor::conflict() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return conflict_;
}

void RunMonitor::poll() {
  const auto now = Clock::now();
  std::lock_guard<std::mutex> lock(mutex_);
  if (conflict_.empty()) {
    const auto duplicates = watch_.duplicates(now);
    if (!duplicates.empty()) {
      conflict_ = service::describe_duplicate(duplicates.begin()->first, duplicates.begin()->second);
      logger("launch")->error("{}; stopping", conflict_);
    }
  }
  update_progress();
  if (!have_estimate_) return;  // start-up: static initialisation waits for the data
  // An estimate is there while corrections arrive and fuse-state does not say lost. The
  // correction rate follows the scans, so a silence of a few scan periods is not yet an outage.
  const double since_estimate = std::chrono::duration<double>(now - last_estimate_).count();
  const bool estimate = since_estimate < std::max(kFlowMinS, kFlowPeriods * health_period_s_) && state_tracking_ != "lost";
  const bool outage = !estimate && data_flows(now);
  if (outage && !in_outage_) {
    in_outage_ = true;
    outage_start_ = state_tracking_ == "lost" ? now : last_estimate_;
  }
  if (in_outage_) {
    const double length = std::chrono::duration<double>(now - outage_start_).count();
    if (!outage) {
      if (length > limits_.loss_after_s) {
        ++outages_over_limit_;
        // When it ended (the log line's time) and how long: to set beside the services' logs.
        logger("launch")->warn("no estimate for {:.1f} s while sensor data flowed (a loss: over {:.1f} s); estimates again",
                               length, limits_.loss_after_s);
      }
      in_outage_ = false;
    }
    longest_outage_s_ = std::max(longest_outage_s_, length);
  }
}

RunMonitor::Verdict RunMonitor::finish(const std::vector<launch::ServiceReport>& reports) {
  std::lock_guard<std::mutex> lock(mutex_);
  Verdict v;
  std::ostringstream out;
  if (in_outage_) {
    const double length = std::chrono::duration<double>(Clock::now() - outage_start_).count();
    longest_outage_s_ = std::max(longest_outage_s_, length);
    if (length > limits_.loss_after_s) ++outages_over_limit_;
  }
  if (outages_over_limit_ > 0) {
    v.losses.push_back(fmt::format("no estimate for up to {:.1f} s while sensor data flowed ({} time(s) over {:.1f} s)",
                                   longest_outage_s_, outages_over_limit_, limits_.loss_after_s));
  }
  if (state_tracking_ == "lost") v.losses.push_back("fuse-state was lost at the end of the run");

  // Scans replayed against poses written.
  const std::uint64_t published = total("fuse-ingest", "scans_published");
  const std::size_t poses = trajectory_file_.empty() ? 0 : line_count(trajectory_file_);
  const std::uint64_t expected = published > skipped_before_first_estimate_ ? published - skipped_before_first_estimate_ : 0;
  const std::uint64_t dropped = expected > poses ? expected - poses : 0;
  if (expected > 0 && static_cast<double>(dropped) > limits_.max_dropped_scans * static_cast<double>(expected)) {
    v.losses.push_back(fmt::format("{} of {} replayed scans have no pose ({:.1f} %, more than {:.1f} %)", dropped, expected,
                                   100.0 * static_cast<double>(dropped) / static_cast<double>(expected),
                                   100.0 * limits_.max_dropped_scans));
  }
  const std::uint64_t journal_errors = total("fuse-map", "journal_errors");
  if (journal_errors > 0) {
    v.losses.push_back(fmt::format("{} journal error(s): the map could not be written when it should have been "
                                   "(see fuse-map's log and fuse-map-ctl stats)",
                                   journal_errors));
  }
  if (const std::uint64_t given_up = total("fuse-update", "observations_given_up")) {
    v.losses.push_back(fmt::format("{} observation(s) given up by fuse-update, never acknowledged by the map server",
                                   given_up));
  }
  // Every acknowledged observation must be in the map directory.
  std::uint64_t acked_total = 0;
  if (!acked_.empty()) {
    try {
      MapServerConfig mc;
      mc.directory = map_dir_;
      MapServerCore map(mc, MapStorage::Access::kReadOnly);
      for (const auto& [session, acked] : acked_) {
        acked_total += acked;
        const std::uint64_t durable = map.acked(session);
        if (durable < acked) {
          v.losses.push_back(fmt::format("session {:016x}: observations {}..{} were acknowledged but are not in {}",
                                         session, durable + 1, acked, map_dir_));
        }
      }
    } catch (const std::exception& e) {
      v.losses.push_back("the map directory " + map_dir_ + " cannot be read back: " + e.what());
    }
  }

  out << "summary:\n";
  out << "  restarts:";
  int ingest_restarts = 0;
  for (const auto& r : reports) {
    out << " " << r.name << " " << r.restarts;
    if (r.name == "fuse-ingest") ingest_restarts = r.restarts;
  }
  out << "\n";
  out << fmt::format("  gaps: fuse-ingest restarted {} time(s), IMU data gaps flagged {}\n", ingest_restarts,
                     total("fuse-state", "imu_gap"));
  out << fmt::format("  scans: {} replayed, {} with a pose, {} skipped before the first initialisation\n", published,
                     poses, skipped_before_first_estimate_);
  out << fmt::format("  estimate: longest outage while data flowed {:.1f} s; fuse-state now {}\n", longest_outage_s_,
                     state_tracking_.empty() ? "unknown" : state_tracking_);
  out << fmt::format("  map: {} session(s), {} observation(s) acknowledged\n", acked_.size(), acked_total);
  for (const auto& [service, names] : summary_counters()) {
    std::string line;
    for (const std::string& n : names) {
      if (const std::uint64_t value = total(service, n)) line += " " + n + "=" + std::to_string(value);
    }
    if (!line.empty()) out << "  " << service << ":" << line << "\n";
  }
  if (const std::uint64_t ambiguous = total("fuse-update", "recovery_ambiguous")) {
    // Not a loss by itself (a handheld sensor that really turned through a gap in a box-shaped room
    // gives it too), but the one sign of a mirrored track there is (docs/chaos.md).
    out << fmt::format("  WARNING: {} ambiguous re-localisation(s): fuse-update turned the heading although a result at "
                       "another heading fitted nearly as well; the estimate may be mirrored (see its log)\n",
                       ambiguous);
  }
  for (const std::string& loss : v.losses) out << "  LOST: " << loss << "\n";
  if (!conflict_.empty()) out << "  FAILED: " << conflict_ << "\n";
  v.summary = out.str();
  return v;
}

}  // namespace fuse::launch_tool

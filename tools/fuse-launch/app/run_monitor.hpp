// What fuse-launch watches on the bus while the services run, and what it concludes at the end:
// nothing may fail silently (docs/architecture.md, "What the launcher calls a loss").
//
// Expected: a data gap. A killed fuse-ingest loses the samples of its downtime, as a real sensor
// link would; the estimator coasts across and re-localises. Counted and summarised, exit 0.
// A loss (exit code 3, each named):
//   - no estimate for more than loss_after_s while sensor data flows (no state/corrected sample
//     arrives, or fuse-state reports lost);
//   - an observation the map server acknowledged that is not in the map directory at the end;
//   - a journal error (the map could not be written when it should have been);
//   - observations fuse-update gave up re-sending (never acknowledged);
//   - more than max_dropped_scans of the replayed scans without a pose, beyond those skipped
//     before the first initialisation;
//   - fuse-state lost at the end of the run.
// It subscribes to health, state/corrected and map/status; reading the trajectory and the map
// directory is left to finish(), once the services have stopped.
//
// While the replay runs it logs a progress line every few seconds (ReplayProgress), from the
// first sample fuse-ingest publishes on.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "fuse/launch/process_supervisor.hpp"
#include "fuse/launch/replay_progress.hpp"
#include "fuse/service/instance_watch.hpp"
#include "fuse/service/system_config.hpp"
#include "fuse/transport/msg_traits.hpp"

namespace fuse::launch_tool {

struct MonitorLimits {
  double loss_after_s = 5.0;          ///< longest estimate outage while data flows
  double max_dropped_scans = 0.01;    ///< fraction of the replayed scans
};

class RunMonitor {
 public:
  /// replay_events: the IMU samples and scans the input holds, when known (for the progress line).
  RunMonitor(const service::SystemConfig& config, std::string trajectory_file, std::string map_dir,
             std::optional<std::uint64_t> replay_events, MonitorLimits limits = {});
  ~RunMonitor();

  /// Call regularly while the services run (the launcher's poll loop).
  void poll();
  /// Two instances of one service alive at once on this domain under this system name (another
  /// system with the same transport.system_name, or a service started twice): why, or empty.
  /// fuse-launch stops the run and fails when it is set.
  std::string conflict() const;

  struct Verdict {
    std::vector<std::string> losses;  ///< empty: nothing was lost
    std::string summary;              ///< restarts, gaps, counters, losses: printed by fuse-launch
  };
  /// After the services have stopped: reads the trajectory and the map directory.
  Verdict finish(const std::vector<launch::ServiceReport>& reports);

 private:
  using Clock = std::chrono::steady_clock;
  struct Instance {
    std::string service;
    std::string state;
    std::map<std::string, std::uint64_t> counters;
    std::string last_error;
  };
  void on_health(const fuse_msgs::Health& h);
  /// Sum over every instance of a service of a counter's last value.
  std::uint64_t total(const std::string& service, const std::string& counter) const;
  bool data_flows(Clock::time_point now) const;
  /// Starts the progress line at the first sample published, then feeds it.
  void update_progress();

  MonitorLimits limits_;
  std::string trajectory_file_, map_dir_;
  double health_period_s_;

  mutable std::mutex mutex_;
  std::map<std::uint64_t, Instance> instances_;
  service::InstanceWatch watch_;  ///< mutex_
  std::string conflict_;          ///< mutex_: the first duplicate seen
  Clock::time_point last_scan_published_{};  ///< when fuse-ingest's scan count last rose
  std::uint64_t scans_published_seen_ = 0;
  bool have_estimate_ = false;
  Clock::time_point last_estimate_{};
  std::uint64_t skipped_before_first_estimate_ = 0;
  bool first_scan_processed_ = false;
  std::string state_tracking_;  ///< fuse-state's newest health state
  std::map<std::uint64_t, std::uint64_t> acked_;  ///< session -> highest acknowledged sequence seen
  // Estimate outages while data flows (wall clock).
  bool in_outage_ = false;
  Clock::time_point outage_start_{};
  double longest_outage_s_ = 0.0;
  int outages_over_limit_ = 0;
  // Progress of the replay.
  std::optional<std::uint64_t> replay_events_;
  std::optional<launch::ReplayProgress> progress_;  ///< from the first sample published on
  std::uint64_t poses_ = 0;                         ///< state/corrected estimates received
  std::uint64_t scans_answered_ = 0;                ///< corrections received (one per scan)
  double newest_scan_t_ = -1.0;                     ///< newest scan end time fuse-update answered

  std::unique_ptr<transport::Participant> participant_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::Health>> health_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::StateEstimate>> corrected_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::Correction>> corrections_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::MapStatus>> status_;
};

}  // namespace fuse::launch_tool

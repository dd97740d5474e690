// Health reporting (issue: every service publishes a heartbeat with its state, counters and
// last error on the `health` topic). A thread publishes what `snapshot` returns every period.
// The reporter also reads everyone's heartbeats (InstanceWatch): while another instance of its
// own service is alive under the same system name, its heartbeat says so (state degraded,
// counter duplicate_instances, last_error), and a service may ask about another service's
// instances (fuse-state refuses IMU samples while two fuse-ingest are alive).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "fuse/service/instance_watch.hpp"
#include "fuse/transport/msg_traits.hpp"

namespace fuse::service {

struct HealthSnapshot {
  std::string state = "running";  ///< starting | running | degraded | stopping
  std::map<std::string, std::uint64_t> counters;
  std::string last_error;
};

class HealthReporter {
 public:
  /// `snapshot` is called on the reporter's thread; it must lock what it reads.
  /// `instance_window_s`: how long a heartbeat counts when telling two live instances of one
  /// service apart from a restart (health.instance_window_s).
  HealthReporter(transport::Participant& participant, std::string service, double period_s, double instance_window_s,
                 std::function<HealthSnapshot()> snapshot);
  ~HealthReporter();
  /// Publishes one heartbeat now (e.g. on stopping).
  void publish_now();
  /// Also hands every heartbeat to `sink` after publishing it (e.g. as ROS 2 diagnostics), and
  /// lets `amend` add to each snapshot before it is published (that output's own counters).
  /// Thread-safe.
  void also_publish(std::function<void(const fuse_msgs::Health&)> sink,
                    std::function<void(HealthSnapshot&)> amend = {});
  /// Why more than one instance of `service` is alive now (empty: at most one is). Thread-safe.
  std::string duplicate(const std::string& service) const;

 private:
  void run();
  void on_health(const fuse_msgs::Health& h);

  std::string service_;
  std::uint64_t instance_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::duration<double> period_;
  std::function<HealthSnapshot()> snapshot_;
  transport::Publisher<fuse_msgs::Health> publisher_;
  std::uint64_t sequence_ = 0;
  mutable std::mutex watch_mutex_;
  InstanceWatch watch_;        ///< watch_mutex_
  std::atomic<bool> reported_duplicate_{false};  ///< the duplicate was logged
  std::unique_ptr<transport::Subscriber<fuse_msgs::Health>> subscriber_;
  std::mutex sink_mutex_;
  std::function<void(const fuse_msgs::Health&)> sink_;  ///< sink_mutex_
  std::function<void(HealthSnapshot&)> amend_;          ///< sink_mutex_
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace fuse::service

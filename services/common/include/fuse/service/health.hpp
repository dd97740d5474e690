// Health reporting (issue: every service publishes a heartbeat with its state, counters and
// last error on the `health` topic). A thread publishes what `snapshot` returns every period.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>

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
  HealthReporter(transport::Participant& participant, std::string service, double period_s,
                 std::function<HealthSnapshot()> snapshot);
  ~HealthReporter();
  /// Publishes one heartbeat now (e.g. on stopping).
  void publish_now();

 private:
  void run();

  std::string service_;
  std::uint64_t instance_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::duration<double> period_;
  std::function<HealthSnapshot()> snapshot_;
  transport::Publisher<fuse_msgs::Health> publisher_;
  std::uint64_t sequence_ = 0;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace fuse::service

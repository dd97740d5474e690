// Two live instances of one service under one system name (issue 16): two fuse-ingest feeding
// one fuse-state, or a second system started on the same domain with the same
// transport.system_name. Every service announces its instance id (random per process start) in
// its heartbeat on `health`; two instances of a service are alive together when their
// heartbeats interleave: each sent at least two after the other's first one, the latest within
// the window. A restart is not that: the old instance's heartbeats end before the new one's
// begin (at most one in flight when it was killed), so the chaos soak's restarts never count.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <vector>

namespace fuse::service {

class InstanceWatch {
 public:
  using Clock = std::chrono::steady_clock;
  /// Heartbeats older than `window_s` are forgotten (a few health periods).
  explicit InstanceWatch(double window_s);

  /// A heartbeat of `service` from `instance`, heard at `t` (in order of t).
  void heard(const std::string& service, std::uint64_t instance, Clock::time_point t);

  /// The instances of `service` alive together with another instance of it at `now`: empty
  /// when there is at most one.
  std::vector<std::uint64_t> concurrent(const std::string& service, Clock::time_point now) const;

  /// Every service with instances alive together, each with its instances.
  std::map<std::string, std::vector<std::uint64_t>> duplicates(Clock::time_point now) const;

 private:
  struct Beats {
    Clock::time_point first;
    std::deque<Clock::time_point> recent;  ///< within the window, oldest first
  };
  /// Heartbeats of `a` at or after `since`, within the window before `now`.
  std::size_t beats_since(const Beats& a, Clock::time_point since, Clock::time_point now) const;

  Clock::duration window_;
  std::map<std::string, std::map<std::uint64_t, Beats>> services_;
};

/// "fuse-state instances 3f2a…, 9b01… are alive at the same time: another system on this domain
/// uses the same transport.system_name, or the service was started twice".
std::string describe_duplicate(const std::string& service, const std::vector<std::uint64_t>& instances);

}  // namespace fuse::service

// Service manager notifications: our own implementation of the sd_notify protocol (systemd,
// sd_notify(3) "Description" and systemd.service(5) Type=notify / WatchdogSec=), no libsystemd.
//
// Protocol: one AF_UNIX datagram per notification, sent to the socket named by $NOTIFY_SOCKET
// (a filesystem path, or an abstract-namespace name when it starts with '@', the '@' standing
// for the leading NUL byte); the payload is newline-separated VARIABLE=VALUE assignments:
//
//   READY=1        start-up is complete (Type=notify: the unit becomes active)
//   STATUS=...     a one-line status shown by `systemctl status`
//   WATCHDOG=1     keep-alive; the manager passes the period in $WATCHDOG_USEC (and the pid it is
//                  meant for in $WATCHDOG_PID) and kills the service when a period passes without one
//   STOPPING=1     the service is shutting down
//
// Without $NOTIFY_SOCKET every call is a no-op, so the services behave the same when started by
// hand, by fuse-launch or by tests. A malformed environment (relative socket path, path too
// long, WATCHDOG_USEC not a positive integer) is logged once naming the variable, counted, and
// the affected part is switched off; a failed send is counted and logged once.
//
// The watchdog ping comes from the service's main loop (watchdog()), rate-limited to half the
// period, so a loop that is stuck stops pinging; loops that wait for data wake at least every
// wake_interval_s() to ping.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>

namespace fuse::service {

/// Where and how often to notify; read from the environment by NotifyConfig::from_environment().
struct NotifyConfig {
  std::string socket;                             ///< $NOTIFY_SOCKET; empty: notifications off
  std::optional<std::chrono::microseconds> watchdog;  ///< $WATCHDOG_USEC when meant for this process
  std::uint64_t environment_errors = 0;           ///< malformed variables (each logged)

  /// $NOTIFY_SOCKET, $WATCHDOG_USEC and $WATCHDOG_PID (sd_watchdog_enabled(3): the period applies
  /// only when WATCHDOG_PID is unset or equals our pid). Never throws: bad values are logged,
  /// counted in environment_errors and switch the affected part off.
  static NotifyConfig from_environment();
};

class Notifier {
 public:
  /// Longest a waiting loop should sleep between watchdog() calls when no watchdog is set.
  static constexpr double kIdleWakeS = 1.0;

  explicit Notifier(NotifyConfig config);
  ~Notifier();
  Notifier(const Notifier&) = delete;
  Notifier& operator=(const Notifier&) = delete;

  bool enabled() const { return fd_ >= 0; }
  bool watchdog_enabled() const { return enabled() && config_.watchdog.has_value(); }

  /// READY=1 (with STATUS=status when not empty).
  void ready(const std::string& status = "");
  /// STATUS=status (one line: newlines are replaced by spaces).
  void status(const std::string& status);
  /// WATCHDOG=1 when half the period has passed since the last one (cheap otherwise).
  void watchdog();
  /// STOPPING=1 (with STATUS=status when not empty); once, later calls are no-ops.
  void stopping(const std::string& status = "");

  /// How long a loop may wait before calling watchdog() again: a quarter of the period (so the
  /// half-period pings are never late by more than that), kIdleWakeS without a watchdog.
  double wake_interval_s() const;

  /// Notifications sent, and failures (environment errors plus failed sends).
  std::uint64_t sent() const { return sent_; }
  std::uint64_t errors() const { return errors_ + config_.environment_errors; }

 private:
  bool send(const std::string& payload);

  NotifyConfig config_;
  int fd_ = -1;
  std::atomic<std::uint64_t> sent_{0};
  std::atomic<std::uint64_t> errors_{0};
  std::atomic<bool> stopping_sent_{false};
  std::mutex watchdog_mutex_;
  std::chrono::steady_clock::time_point last_ping_{};
};

/// The process's notifier, configured from the environment on first use (thread-safe).
Notifier& notifier();

/// wait_for_stop(seconds) (runtime.hpp) in slices of notifier().wake_interval_s(), pinging the
/// watchdog before and between them: for loops that wait for data or for a schedule. True when a
/// stop was requested.
bool wait_for_stop_alive(double seconds);

}  // namespace fuse::service

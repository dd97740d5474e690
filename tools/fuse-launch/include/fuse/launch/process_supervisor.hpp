// ProcessSupervisor: a set of named services, each a child process with its log at
// <log_dir>/<name>.log. It reaps them, classifies every exit it did not ask for (finished,
// failed, or restarted after a backoff), and stops them, the last started first, with SIGTERM
// and then SIGKILL after a timeout.
// Restarts: the backoff doubles with each death that follows a short run, and a service that
// keeps dying early is given up after max_restarts such deaths (a crash loop); a process that
// ran for healthy_after before dying starts the count afresh, so a long-running system survives
// any number of occasional deaths. Exit codes in never_restart (usage or config error 2,
// unreadable input 4) are not restarted: restarting cannot fix them.
// Single-threaded: call it from one thread (the one that started the services).
#pragma once

#include <chrono>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "fuse/launch/process.hpp"

namespace fuse::launch {

struct ServiceSpec {
  std::string name;               ///< also names the log file
  std::vector<std::string> argv;  ///< argv[0] is the executable's path
  bool restart = false;           ///< restart it when it dies unexpectedly
  bool exit_zero_is_done = false; ///< exit code 0 means its work is complete (e.g. a replay)
};

/// Exit codes of the FUSE services that restarting cannot fix (docs/architecture.md).
inline constexpr int kExitUsage = 2;  ///< usage or config error
inline constexpr int kExitInput = 4;  ///< the input (recording, sensor, calibration) cannot be read

enum class ServiceState {
  running,
  restarting,  ///< died unexpectedly; restarts when its backoff has passed
  done,        ///< exited 0 by itself, as its spec allows
  failed,      ///< died unexpectedly and is not (or no more) restarted
  stopped,     ///< stopped by stop()/stop_all()
};
const char* to_string(ServiceState state);

struct SupervisorOptions {
  std::string log_dir;  ///< created when missing
  int max_restarts = 5;  ///< consecutive early deaths (each within healthy_after of its start)
  std::chrono::milliseconds restart_backoff{250};  ///< before the first restart; doubles after
  std::chrono::milliseconds max_backoff{5000};
  std::chrono::milliseconds healthy_after{10000};  ///< a run this long resets backoff and count
  std::vector<int> never_restart{kExitUsage, kExitInput};
};

/// What happened to one service.
struct ServiceReport {
  std::string name;
  ServiceState state = ServiceState::running;
  int restarts = 0;            ///< in total
  int early_deaths = 0;        ///< consecutive deaths within healthy_after of a start
  std::string failure;         ///< why it failed (no restarts left, exit code not restartable)
  std::optional<ExitStatus> last_exit;  ///< of its latest process, once that has ended
  bool escalated = false;               ///< stopping it needed SIGKILL
  /// It had died and was waiting for its restart when it was stopped: down at the end of the
  /// run, not a service that failed to stop (last_exit is the death the restart was for).
  bool down_at_stop = false;
  std::string log_path;
};

class ProcessSupervisor {
 public:
  explicit ProcessSupervisor(SupervisorOptions options);
  /// Stops every service still running (SIGTERM, SIGKILL after 2 s).
  ~ProcessSupervisor();
  ProcessSupervisor(const ProcessSupervisor&) = delete;
  ProcessSupervisor& operator=(const ProcessSupervisor&) = delete;

  /// Spawns a service. Throws std::invalid_argument for a name already used and
  /// std::runtime_error when it cannot be spawned.
  void start(const ServiceSpec& spec);

  /// Reaps services that exited, classifies their exits and restarts those whose backoff has
  /// passed. Never blocks; call it regularly.
  void poll();

  /// Waits up to timeout for the service's current process to end (then classified as by
  /// poll()); nullopt when it is still running or is not running a process.
  std::optional<ExitStatus> wait(const std::string& name, std::chrono::milliseconds timeout);

  /// SIGTERM, then SIGKILL after timeout; the service is not restarted afterwards.
  ServiceReport stop(const std::string& name, std::chrono::milliseconds timeout);
  /// stop() for every service, in reverse start order.
  std::vector<ServiceReport> stop_all(std::chrono::milliseconds timeout);

  bool signal(const std::string& name, int sig);
  bool is_running(const std::string& name);
  ServiceState state(const std::string& name) const;
  int restarts(const std::string& name) const;
  pid_t pid(const std::string& name) const;  ///< -1 when no process is running
  std::string log_path(const std::string& name) const;
  ServiceReport report(const std::string& name) const;
  std::vector<std::string> names() const { return order_; }  ///< in start order

 private:
  struct Service {
    ServiceSpec spec;
    std::optional<Process> process;
    ServiceReport report;
    std::chrono::steady_clock::time_point restart_at;
    std::chrono::steady_clock::time_point started_at;
  };

  Service& find(const std::string& name);
  const Service& find(const std::string& name) const;
  void spawn(Service& s);
  void reap(Service& s);  ///< classifies the exit of a running service's process, if it ended
  void on_exit(Service& s, const ExitStatus& status);
  void restart(Service& s);

  SupervisorOptions options_;
  std::map<std::string, Service> services_;
  std::vector<std::string> order_;
};

}  // namespace fuse::launch

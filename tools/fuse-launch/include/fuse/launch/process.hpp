// One child process: spawned from an argv with its output appended to a log file, signalled,
// waited for with a timeout, and terminated with escalation (SIGTERM, then SIGKILL).
#pragma once

#include <sys/types.h>

#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "fuse/launch/exit_status.hpp"

namespace fuse::launch {

class Process {
 public:
  /// Starts argv[0] (a path to an executable) with argv. Its stdout and stderr are appended to
  /// log_path, stdin reads /dev/null. The child leads its own process group (signals reach the
  /// children it starts, a terminal's Ctrl-C reaches only the launcher) and gets SIGTERM when
  /// the thread that spawned it exits. Throws std::runtime_error when the program is not
  /// executable, the log cannot be opened or fork fails.
  static Process spawn(const std::vector<std::string>& argv, const std::string& log_path);

  Process(Process&& other) noexcept;
  Process& operator=(Process&& other) noexcept;
  Process(const Process&) = delete;
  Process& operator=(const Process&) = delete;
  /// A child still running is killed (SIGKILL to its group) and reaped: no orphans, no zombies.
  ~Process();

  pid_t pid() const { return pid_; }

  /// Sends sig to the child's process group; false when it has already been reaped.
  bool signal(int sig);

  /// Reaps the child if it has exited (never blocks); its status from then on.
  std::optional<ExitStatus> poll();
  bool is_running() { return !poll().has_value(); }

  /// Waits up to timeout for the child to exit; nullopt when it is still running.
  std::optional<ExitStatus> wait_for(std::chrono::milliseconds timeout);

  struct Termination {
    ExitStatus status;
    bool escalated = false;  ///< it ignored SIGTERM for the whole timeout and got SIGKILL
  };
  /// SIGTERM, waits up to timeout, then SIGKILL; returns how it ended.
  Termination terminate(std::chrono::milliseconds timeout);

 private:
  explicit Process(pid_t pid) : pid_(pid) {}
  void kill_and_reap();

  pid_t pid_ = -1;
  std::optional<ExitStatus> exit_;
};

}  // namespace fuse::launch

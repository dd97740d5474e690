// How a child process ended: an exit code or a signal (from a waitpid status).
#pragma once

#include <string>

namespace fuse::launch {

struct ExitStatus {
  bool signaled = false;  ///< killed by `signal`; otherwise exited with `code`
  int code = 0;
  int signal = 0;

  static ExitStatus from_wait_status(int status);
  bool success() const { return !signaled && code == 0; }
  /// "exit code 3" or "killed by signal 9 (SIGKILL)".
  std::string describe() const;
};

}  // namespace fuse::launch

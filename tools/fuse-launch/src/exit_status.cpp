#include "fuse/launch/exit_status.hpp"

#include <sys/wait.h>

#include <csignal>

namespace fuse::launch {

namespace {
const char* signal_name(int sig) {
  switch (sig) {
    case SIGTERM: return "SIGTERM";
    case SIGKILL: return "SIGKILL";
    case SIGINT: return "SIGINT";
    case SIGSEGV: return "SIGSEGV";
    case SIGABRT: return "SIGABRT";
    case SIGBUS: return "SIGBUS";
    case SIGFPE: return "SIGFPE";
    case SIGHUP: return "SIGHUP";
    case SIGPIPE: return "SIGPIPE";
    default: return "";
  }
}
}  // namespace

ExitStatus ExitStatus::from_wait_status(int status) {
  ExitStatus s;
  if (WIFSIGNALED(status)) {
    s.signaled = true;
    s.signal = WTERMSIG(status);
  } else {
    s.code = WEXITSTATUS(status);
  }
  return s;
}

std::string ExitStatus::describe() const {
  if (!signaled) return "exit code " + std::to_string(code);
  const std::string name = signal_name(signal);
  return "killed by signal " + std::to_string(signal) + (name.empty() ? "" : " (" + name + ")");
}

}  // namespace fuse::launch

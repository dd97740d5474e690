#include "fuse/launch/process.hpp"

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <stdexcept>
#include <thread>

namespace fuse::launch {

namespace {
constexpr auto kPollInterval = std::chrono::milliseconds(5);

int open_or_throw(const std::string& path, int flags, const std::string& what) {
  const int fd = ::open(path.c_str(), flags | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("cannot open " + what + " '" + path + "': " + std::strerror(errno));
  return fd;
}

/// In the child, between fork and exec: only async-signal-safe calls.
[[noreturn]] void exec_child(char* const* argv, int log_fd, int null_fd, pid_t parent, const std::string& failure) {
  ::setpgid(0, 0);
  ::prctl(PR_SET_PDEATHSIG, SIGTERM);
  if (::getppid() != parent) ::_exit(127);  // the launcher died before prctl took effect
  ::dup2(null_fd, STDIN_FILENO);
  ::dup2(log_fd, STDOUT_FILENO);
  ::dup2(log_fd, STDERR_FILENO);
  ::execv(argv[0], argv);
  [[maybe_unused]] const auto n = ::write(STDERR_FILENO, failure.data(), failure.size());
  ::_exit(127);
}
}  // namespace

Process Process::spawn(const std::vector<std::string>& argv, const std::string& log_path) {
  if (argv.empty()) throw std::runtime_error("cannot spawn an empty command line");
  if (::access(argv[0].c_str(), X_OK) != 0) {
    throw std::runtime_error("'" + argv[0] + "' is not an executable: " + std::strerror(errno));
  }
  // Everything the child needs is prepared here: after fork it may not allocate.
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const std::string failure = "fuse-launch: exec of '" + argv[0] + "' failed\n";
  const int log_fd = open_or_throw(log_path, O_WRONLY | O_CREAT | O_APPEND, "log file");
  const int null_fd = open_or_throw("/dev/null", O_RDONLY, "input");
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid == 0) exec_child(args.data(), log_fd, null_fd, parent, failure);
  const int fork_errno = errno;
  ::close(log_fd);
  ::close(null_fd);
  if (pid < 0) throw std::runtime_error(std::string("fork failed: ") + std::strerror(fork_errno));
  ::setpgid(pid, pid);  // also from this side, so that signal() cannot race the child's setpgid
  return Process(pid);
}

Process::Process(Process&& other) noexcept : pid_(other.pid_), exit_(other.exit_) { other.pid_ = -1; }

Process& Process::operator=(Process&& other) noexcept {
  if (this != &other) {
    kill_and_reap();
    pid_ = other.pid_;
    exit_ = other.exit_;
    other.pid_ = -1;
  }
  return *this;
}

Process::~Process() { kill_and_reap(); }

void Process::kill_and_reap() {
  if (pid_ > 0 && !poll()) {
    signal(SIGKILL);
    int status = 0;
    while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
  }
  pid_ = -1;
}

bool Process::signal(int sig) {
  if (pid_ <= 0 || exit_) return false;
  return ::kill(-pid_, sig) == 0 || ::kill(pid_, sig) == 0;
}

std::optional<ExitStatus> Process::poll() {
  if (exit_ || pid_ <= 0) return exit_;
  int status = 0;
  const pid_t r = ::waitpid(pid_, &status, WNOHANG);
  if (r == pid_) {
    exit_ = ExitStatus::from_wait_status(status);
  } else if (r < 0 && errno == ECHILD) {
    exit_ = ExitStatus{false, -1, 0};  // reaped elsewhere: the status is lost
  }
  return exit_;
}

std::optional<ExitStatus> Process::wait_for(std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!poll()) {
    if (std::chrono::steady_clock::now() >= end) return std::nullopt;
    std::this_thread::sleep_for(kPollInterval);
  }
  return exit_;
}

Process::Termination Process::terminate(std::chrono::milliseconds timeout) {
  if (pid_ <= 0) throw std::logic_error("terminate() on a moved-from Process");
  Termination t;
  signal(SIGTERM);
  if (auto s = wait_for(timeout)) {
    t.status = *s;
    return t;
  }
  t.escalated = true;
  signal(SIGKILL);
  while (!poll()) std::this_thread::sleep_for(kPollInterval);
  t.status = *exit_;
  return t;
}

}  // namespace fuse::launch

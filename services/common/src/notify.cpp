// The sd_notify datagram protocol (see notify.hpp for the messages and the spec sections).
#include "fuse/service/notify.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdlib>
#include <cstring>

#include "fuse/core/logging.hpp"
#include "fuse/service/runtime.hpp"

namespace fuse::service {

namespace {

auto log() { return fuse::logger("notify"); }

/// A decimal unsigned integer with nothing else around it; nullopt otherwise.
std::optional<std::uint64_t> parse_unsigned(const std::string& text) {
  if (text.empty() || text.size() > 19 || !std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return std::nullopt;
  }
  return std::strtoull(text.c_str(), nullptr, 10);
}

std::string one_line(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  return s;
}

}  // namespace

NotifyConfig NotifyConfig::from_environment() {
  NotifyConfig c;
  if (const char* s = std::getenv("NOTIFY_SOCKET"); s != nullptr && *s != '\0') {
    const std::string socket = s;
    // sockaddr_un.sun_path holds the path and its NUL (or '\0' + the abstract name).
    if (socket[0] != '/' && socket[0] != '@') {
      log()->error("NOTIFY_SOCKET '{}' is neither an absolute path nor an abstract name ('@...'): not notifying", socket);
      ++c.environment_errors;
    } else if (socket.size() < 2 || socket.size() >= sizeof(sockaddr_un::sun_path)) {
      log()->error("NOTIFY_SOCKET '{}' has a length of {} (1..{} characters after the first): not notifying", socket,
                   socket.size(), sizeof(sockaddr_un::sun_path) - 2);
      ++c.environment_errors;
    } else {
      c.socket = socket;
    }
  }
  if (const char* w = std::getenv("WATCHDOG_USEC"); w != nullptr && *w != '\0') {
    const auto usec = parse_unsigned(w);
    bool ours = true;
    if (const char* p = std::getenv("WATCHDOG_PID"); p != nullptr && *p != '\0') {
      const auto pid = parse_unsigned(p);
      if (!pid) {
        log()->error("WATCHDOG_PID '{}' is not a process id: no watchdog pings", p);
        ++c.environment_errors;
        ours = false;
      } else if (*pid != static_cast<std::uint64_t>(::getpid())) {
        log()->debug("WATCHDOG_PID {} is another process: no watchdog pings", *pid);
        ours = false;
      }
    }
    if (!usec || *usec == 0) {
      log()->error("WATCHDOG_USEC '{}' is not a positive number of microseconds: no watchdog pings", w);
      ++c.environment_errors;
    } else if (ours) {
      c.watchdog = std::chrono::microseconds(*usec);
    }
  }
  return c;
}

Notifier::Notifier(NotifyConfig config) : config_(std::move(config)) {
  if (config_.socket.empty()) return;
  fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) {
    ++errors_;
    log()->error("cannot create the notification socket: {}: not notifying", std::strerror(errno));
    return;
  }
  if (config_.watchdog) {
    log()->info("service manager watchdog: {:.3f} s, pinging every {:.3f} s", config_.watchdog->count() * 1e-6,
                config_.watchdog->count() * 0.5e-6);
  }
}

Notifier::~Notifier() {
  if (fd_ >= 0) ::close(fd_);
}

bool Notifier::send(const std::string& payload) {
  if (fd_ < 0) return false;
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, config_.socket.data(), config_.socket.size());
  socklen_t length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + config_.socket.size());
  if (config_.socket[0] == '@') {
    addr.sun_path[0] = '\0';  // abstract namespace: the name's exact length, no trailing NUL
  } else {
    length += 1;  // the path's NUL
  }
  const ssize_t n = ::sendto(fd_, payload.data(), payload.size(), MSG_NOSIGNAL, reinterpret_cast<sockaddr*>(&addr), length);
  if (n != static_cast<ssize_t>(payload.size())) {
    const int err = errno;
    if (errors_++ == 0) {  // once: a manager that went away would otherwise flood the log
      log()->warn("notification to {} failed: {} (further failures are only counted)", config_.socket,
                  n < 0 ? std::strerror(err) : "short write");
    }
    return false;
  }
  ++sent_;
  return true;
}

void Notifier::ready(const std::string& status) {
  send(status.empty() ? "READY=1" : "READY=1\nSTATUS=" + one_line(status));
}

void Notifier::status(const std::string& status) { send("STATUS=" + one_line(status)); }

void Notifier::watchdog() {
  if (!watchdog_enabled()) return;
  const auto now = std::chrono::steady_clock::now();
  {
    std::lock_guard<std::mutex> lock(watchdog_mutex_);
    if (last_ping_ != std::chrono::steady_clock::time_point{} && now - last_ping_ < *config_.watchdog / 2) return;
    last_ping_ = now;
  }
  send("WATCHDOG=1");
}

void Notifier::stopping(const std::string& status) {
  if (stopping_sent_.exchange(true)) return;
  send(status.empty() ? "STOPPING=1" : "STOPPING=1\nSTATUS=" + one_line(status));
}

double Notifier::wake_interval_s() const {
  if (!watchdog_enabled()) return kIdleWakeS;
  return std::min(kIdleWakeS, std::chrono::duration<double>(*config_.watchdog).count() / 4.0);
}

Notifier& notifier() {
  static Notifier instance(NotifyConfig::from_environment());
  return instance;
}

bool wait_for_stop_alive(double seconds) {
  Notifier& n = notifier();
  for (;;) {
    n.watchdog();
    const double slice = std::min(seconds, n.wake_interval_s());
    if (wait_for_stop(slice)) return true;
    seconds -= slice;
    if (seconds <= 0.0) {
      n.watchdog();
      return false;
    }
  }
}

}  // namespace fuse::service

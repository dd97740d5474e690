// Service manager notifications (services/common/include/fuse/service/notify.hpp: the sd_notify
// datagram protocol of systemd, Type=notify and WatchdogSec=).
//
// In process: the environment is checked (bad values counted, notifications off) and messages
// arrive as whole datagrams on path and abstract sockets.
// As processes: each real service binary runs with NOTIFY_SOCKET naming a datagram socket this
// test owns and WATCHDOG_USEC set, as systemd starts it. READY=1 must arrive, then WATCHDOG=1
// repeatedly (no data flows: the services are alone on their DDS domain) with no gap as long as
// the watchdog period, and after SIGTERM STOPPING=1 and exit code 0. fuse-map: observations
// acknowledged before SIGTERM are in its map after a restart; on a map directory it cannot write
// it is READY (degraded, in STATUS) and pinged; on one another fuse-map holds, no READY, exit 2.
// DDS domain ids 80..89 belong to this file.
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "fuse/launch/process.hpp"
#include "fuse/service/notify.hpp"
#include "fuse/transport/msg_traits.hpp"
#include "fuse/transport/qos.hpp"
#include "fuse/transport/transport.hpp"
#include "fuse/transport/typed.hpp"

namespace fuse::deploy_test {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::string read_text(const fs::path& file) {
  std::ifstream f(file);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

fs::path scratch_dir(const std::string& name) {
  const fs::path dir = fs::path(FUSE_TEST_OUT) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

/// The receiving end of NOTIFY_SOCKET: a bound AF_UNIX datagram socket (path or abstract).
class NotifySocket {
 public:
  /// `name`: a filesystem path, or "@name" for the abstract namespace.
  explicit NotifySocket(std::string name) : name_(std::move(name)) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0) throw std::runtime_error("socket: " + std::string(std::strerror(errno)));
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::memcpy(addr.sun_path, name_.data(), name_.size());
    socklen_t length = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + name_.size());
    if (name_[0] == '@') {
      addr.sun_path[0] = '\0';
    } else {
      ::unlink(name_.c_str());
      length += 1;
    }
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), length) != 0) {
      throw std::runtime_error("bind " + name_ + ": " + std::strerror(errno));
    }
  }
  ~NotifySocket() {
    ::close(fd_);
    if (name_[0] == '/') ::unlink(name_.c_str());
  }
  const std::string& name() const { return name_; }

  /// The next datagram, or nullopt after `timeout`.
  std::optional<std::string> receive(std::chrono::milliseconds timeout) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(timeout.count())) <= 0) return std::nullopt;
    char buffer[4096];
    const ssize_t n = ::recv(fd_, buffer, sizeof(buffer), 0);
    if (n < 0) return std::nullopt;
    return std::string(buffer, static_cast<std::size_t>(n));
  }

 private:
  std::string name_;
  int fd_ = -1;
};

/// Every datagram with its arrival time, read by a background thread.
class NotifyLog {
 public:
  explicit NotifyLog(NotifySocket& socket) : socket_(socket), reader_([this] { read(); }) {}
  ~NotifyLog() {
    done_ = true;
    reader_.join();
  }
  struct Message {
    Clock::time_point at;
    std::string text;
  };
  std::vector<Message> messages() {
    std::lock_guard<std::mutex> lock(mutex_);
    return messages_;
  }
  /// The arrival of the first message containing `line` as one of its lines.
  std::optional<Clock::time_point> first(const std::string& line) {
    for (const auto& m : messages()) {
      std::istringstream in(m.text);
      for (std::string l; std::getline(in, l);) {
        if (l == line) return m.at;
      }
    }
    return std::nullopt;
  }
  bool wait_for(const std::string& line, std::chrono::milliseconds timeout) {
    const auto end = Clock::now() + timeout;
    while (Clock::now() < end) {
      if (first(line)) return true;
      std::this_thread::sleep_for(10ms);
    }
    return first(line).has_value();
  }
  /// Arrival times of the messages that are exactly `text`, after `from`.
  std::vector<Clock::time_point> times_of(const std::string& text, Clock::time_point from) {
    std::vector<Clock::time_point> t;
    for (const auto& m : messages()) {
      if (m.text == text && m.at >= from) t.push_back(m.at);
    }
    return t;
  }
  std::string dump() {
    std::string s;
    for (const auto& m : messages()) s += "[" + m.text + "] ";
    return s;
  }

 private:
  void read() {
    while (!done_) {
      if (auto m = socket_.receive(50ms)) {
        std::lock_guard<std::mutex> lock(mutex_);
        messages_.push_back({Clock::now(), *m});
      }
    }
  }
  NotifySocket& socket_;
  std::atomic<bool> done_{false};
  std::mutex mutex_;
  std::vector<Message> messages_;
  std::thread reader_;
};

/// Sets environment variables for the children spawned while it lives (restores them after).
class ScopedEnv {
 public:
  ScopedEnv(std::vector<std::pair<std::string, std::string>> vars, std::vector<std::string> unset = {}) {
    for (const auto& [k, v] : vars) save(k), ::setenv(k.c_str(), v.c_str(), 1);
    for (const auto& k : unset) save(k), ::unsetenv(k.c_str());
  }
  ~ScopedEnv() {
    for (const auto& [k, v] : saved_) {
      if (v) {
        ::setenv(k.c_str(), v->c_str(), 1);
      } else {
        ::unsetenv(k.c_str());
      }
    }
  }

 private:
  void save(const std::string& k) {
    const char* v = std::getenv(k.c_str());
    saved_.emplace_back(k, v ? std::optional<std::string>(v) : std::nullopt);
  }
  std::vector<std::pair<std::string, std::optional<std::string>>> saved_;
};

// ---- in process ----------------------------------------------------------------------------

TEST(NotifyConfig, UnsetEnvironmentMeansNoNotifications) {
  ScopedEnv env({}, {"NOTIFY_SOCKET", "WATCHDOG_USEC", "WATCHDOG_PID"});
  const auto c = service::NotifyConfig::from_environment();
  EXPECT_TRUE(c.socket.empty());
  EXPECT_FALSE(c.watchdog.has_value());
  EXPECT_EQ(c.environment_errors, 0u);
  service::Notifier n(c);
  EXPECT_FALSE(n.enabled());
  n.ready();
  n.watchdog();
  n.stopping();
  EXPECT_EQ(n.sent(), 0u);
  EXPECT_EQ(n.errors(), 0u);
  EXPECT_DOUBLE_EQ(n.wake_interval_s(), service::Notifier::kIdleWakeS);
}

struct BadEnvironment {
  const char* name;
  const char* socket;
  const char* usec;
  const char* pid;
  bool socket_kept;
  bool watchdog_kept;
  std::uint64_t errors;
};

void PrintTo(const BadEnvironment& b, std::ostream* os) { *os << b.name; }

class NotifyBadEnvironment : public ::testing::TestWithParam<BadEnvironment> {};

TEST_P(NotifyBadEnvironment, IsCountedAndSwitchesThatPartOff) {
  const BadEnvironment& b = GetParam();
  std::vector<std::pair<std::string, std::string>> set;
  std::vector<std::string> unset;
  for (const auto& [name, value] : {std::pair<const char*, const char*>{"NOTIFY_SOCKET", b.socket},
                                    {"WATCHDOG_USEC", b.usec}, {"WATCHDOG_PID", b.pid}}) {
    if (value) {
      set.emplace_back(name, value);
    } else {
      unset.emplace_back(name);
    }
  }
  ScopedEnv env(set, unset);
  const auto c = service::NotifyConfig::from_environment();
  EXPECT_EQ(!c.socket.empty(), b.socket_kept);
  EXPECT_EQ(c.watchdog.has_value(), b.watchdog_kept);
  EXPECT_EQ(c.environment_errors, b.errors);
}

const std::string kLongPath = "/" + std::string(120, 'x');
INSTANTIATE_TEST_SUITE_P(
    Environment, NotifyBadEnvironment,
    ::testing::Values(BadEnvironment{"relative_socket", "run/notify", nullptr, nullptr, false, false, 1},
                      BadEnvironment{"socket_path_too_long", kLongPath.c_str(), nullptr, nullptr, false, false, 1},
                      BadEnvironment{"bare_at", "@", nullptr, nullptr, false, false, 1},
                      BadEnvironment{"usec_not_a_number", "/run/n", "30s", nullptr, true, false, 1},
                      BadEnvironment{"usec_zero", "/run/n", "0", nullptr, true, false, 1},
                      BadEnvironment{"usec_negative", "/run/n", "-5", nullptr, true, false, 1},
                      BadEnvironment{"pid_garbage", "/run/n", "1000000", "12ab", true, false, 1},
                      BadEnvironment{"pid_of_another_process", "/run/n", "1000000", "1", true, false, 0},
                      BadEnvironment{"valid", "@fuse-notify", "1000000", nullptr, true, true, 0}),
    [](const auto& info) { return std::string(info.param.name); });

class NotifySocketKind : public ::testing::TestWithParam<bool> {};

TEST_P(NotifySocketKind, MessagesArriveAsWholeDatagrams) {
  const bool abstract = GetParam();
  const fs::path dir = scratch_dir(abstract ? "notify-inproc-abstract" : "notify-inproc-path");
  NotifySocket socket(abstract ? "@fuse-deploy-test-" + std::to_string(::getpid()) : (dir / "notify.sock").string());
  service::NotifyConfig c;
  c.socket = socket.name();
  c.watchdog = std::chrono::microseconds(200000);
  service::Notifier n(c);
  ASSERT_TRUE(n.enabled());
  EXPECT_DOUBLE_EQ(n.wake_interval_s(), 0.05);
  n.ready("two\nlines");
  EXPECT_EQ(socket.receive(1s).value_or("<none>"), "READY=1\nSTATUS=two lines");
  n.watchdog();
  EXPECT_EQ(socket.receive(1s).value_or("<none>"), "WATCHDOG=1");
  n.watchdog();  // within half the period: not sent
  EXPECT_FALSE(socket.receive(20ms).has_value());
  std::this_thread::sleep_for(110ms);
  n.watchdog();
  EXPECT_EQ(socket.receive(1s).value_or("<none>"), "WATCHDOG=1");
  n.stopping();
  n.stopping();  // once
  EXPECT_EQ(socket.receive(1s).value_or("<none>"), "STOPPING=1");
  EXPECT_FALSE(socket.receive(20ms).has_value());
  EXPECT_EQ(n.sent(), 4u);
  EXPECT_EQ(n.errors(), 0u);
}

TEST(Notifier, FailedSendsAreCounted) {
  service::NotifyConfig c;
  c.socket = (scratch_dir("notify-nobody") / "nobody.sock").string();  // nobody listens
  service::Notifier n(c);
  n.ready();
  n.status("x");
  EXPECT_EQ(n.sent(), 0u);
  EXPECT_EQ(n.errors(), 2u);
}

INSTANTIATE_TEST_SUITE_P(Socket, NotifySocketKind, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? std::string("abstract") : std::string("path"); });

// ---- the service binaries ------------------------------------------------------------------

constexpr auto kWatchdog = 400ms;  // WATCHDOG_USEC: pings expected every 200 ms

/// Waits until `count` messages that are exactly `text` arrived after `from`.
bool wait_until_count(NotifyLog& log, const std::string& text, Clock::time_point from, std::size_t count,
                      std::chrono::milliseconds timeout) {
  const auto end = Clock::now() + timeout;
  while (log.times_of(text, from).size() < count && Clock::now() < end) std::this_thread::sleep_for(10ms);
  return log.times_of(text, from).size() >= count;
}

struct ServiceCase {
  const char* name;
  int domain;
  bool abstract_socket;
};

void PrintTo(const ServiceCase& s, std::ostream* os) { *os << s.name; }

class ServiceNotify : public ::testing::TestWithParam<ServiceCase> {};

std::vector<std::string> service_argv(const ServiceCase& s, const fs::path& dir) {
  std::vector<std::string> argv{std::string(FUSE_BIN_DIR) + "/" + s.name, "--config",
                                std::string(FUSE_CONFIG_DIR) + "/mid360.yaml", "--set",
                                "transport.domain_id=" + std::to_string(s.domain), "--set", "health.period_s=0.2"};
  const std::string name = s.name;
  if (name == "fuse-map") {
    argv.insert(argv.end(), {"--map-dir", (dir / "map").string()});
  } else if (name == "fuse-ingest") {
    // Alone on its domain it waits for fuse-state and fuse-update (no data flows) up to the
    // start wait; SIGTERM comes within it.
    argv.insert(argv.end(), {"--input", std::string(FUSE_DEPLOY_DATA) + "/recording.mcap", "--mode", "realtime",
                             "--set", "ingest.start_wait_s=30"});
  }
  return argv;
}

TEST_P(ServiceNotify, ReadyWatchdogStoppingAndCleanExit) {
  const ServiceCase& s = GetParam();
  if (std::string(s.name) == "fuse-ingest" && !fs::exists(std::string(FUSE_DEPLOY_DATA) + "/recording.mcap")) {
    GTEST_SKIP() << "no recording at " << FUSE_DEPLOY_DATA << " (made by the ctest fixture fuse_deploy_data)";
  }
  const fs::path dir = scratch_dir(std::string("notify-") + s.name);
  NotifySocket socket(s.abstract_socket ? "@fuse-deploy-" + std::string(s.name) + "-" + std::to_string(::getpid())
                                        : (dir / "notify.sock").string());
  NotifyLog log(socket);
  const std::string out = (dir / "service.log").string();
  std::optional<launch::Process> p;
  {
    ScopedEnv env({{"NOTIFY_SOCKET", socket.name()},
                   {"WATCHDOG_USEC", std::to_string(std::chrono::microseconds(kWatchdog).count())}},
                  {"WATCHDOG_PID"});
    p.emplace(launch::Process::spawn(service_argv(s, dir), out));
  }
  ASSERT_TRUE(log.wait_for("READY=1", 30s)) << log.dump() << "\n" << read_text(out);
  const Clock::time_point ready = *log.first("READY=1");

  // Watch the pings for 2 s: at least 6 (one per 200 ms), never a gap as long as the period.
  std::this_thread::sleep_for(2s);
  const auto pings = log.times_of("WATCHDOG=1", ready);
  EXPECT_GE(pings.size(), 6u) << log.dump();
  double largest_gap_s = pings.empty() ? 99.0 : std::chrono::duration<double>(pings.front() - ready).count();
  for (std::size_t i = 1; i < pings.size(); ++i) {
    largest_gap_s = std::max(largest_gap_s, std::chrono::duration<double>(pings[i] - pings[i - 1]).count());
  }
  EXPECT_LT(largest_gap_s, std::chrono::duration<double>(kWatchdog).count()) << log.dump();
  ASSERT_TRUE(p->is_running()) << read_text(out);
  EXPECT_FALSE(log.first("STOPPING=1").has_value());

  ASSERT_TRUE(p->signal(SIGTERM));
  EXPECT_TRUE(log.wait_for("STOPPING=1", 20s)) << log.dump();
  const auto status = p->wait_for(30s);
  ASSERT_TRUE(status.has_value()) << "still running 30 s after SIGTERM\n" << read_text(out);
  EXPECT_TRUE(status->success()) << status->describe() << "\n" << read_text(out);
  std::cout << s.name << ": READY, " << pings.size() << " watchdog pings in 2 s (largest gap "
            << static_cast<int>(largest_gap_s * 1000) << " ms), STOPPING, " << status->describe() << "\n";
}

INSTANTIATE_TEST_SUITE_P(Services, ServiceNotify,
                         ::testing::Values(ServiceCase{"fuse-map", 80, false}, ServiceCase{"fuse-state", 81, true},
                                           ServiceCase{"fuse-update", 82, false},
                                           ServiceCase{"fuse-ingest", 83, true}),
                         [](const auto& info) {
                           std::string n = info.param.name;
                           return n.substr(n.find('-') + 1);
                         });

// fuse-map on SIGTERM: what it acknowledged is journaled; a restart on the same directory has it.
TEST(MapServiceSigterm, AcknowledgedObservationsSurviveARestart) {
  constexpr int kDomain = 85;
  constexpr std::uint64_t kSession = 77, kObservations = 20, kPointsEach = 25;
  const fs::path dir = scratch_dir("notify-map-journal");
  transport::TransportConfig tc;
  tc.domain_id = kDomain;
  auto participant = transport::make_participant(tc, "deploy-test");
  std::mutex mutex;
  std::optional<fuse_msgs::MapStatus> status;
  transport::Publisher<fuse_msgs::MapObservation> observations(*participant, transport::topics::kObservation);
  transport::Subscriber<fuse_msgs::MapStatus> statuses(*participant, transport::topics::kMapStatus,
                                                       [&](const fuse_msgs::MapStatus& m) {
                                                         std::lock_guard<std::mutex> lock(mutex);
                                                         status = m;
                                                       });
  auto latest = [&] {
    std::lock_guard<std::mutex> lock(mutex);
    return status;
  };
  auto wait = [](const std::function<bool()>& done, std::chrono::milliseconds timeout) {
    const auto end = Clock::now() + timeout;
    while (!done() && Clock::now() < end) std::this_thread::sleep_for(10ms);
    return done();
  };
  const ServiceCase map{"fuse-map", kDomain, false};
  const std::string out = (dir / "map.log").string();
  {
    auto p = launch::Process::spawn(service_argv(map, dir), out);
    ASSERT_TRUE(wait([&] { return observations.matched() > 0 && latest().has_value(); }, 30s)) << read_text(out);
    // Points on a 1 m grid, each once: the map must end up holding every one of them.
    auto send = [&](std::uint64_t seq) {
      fuse_msgs::MapObservation o;
      o.session(kSession);
      o.sequence_number(seq);
      o.t(0.1 * static_cast<double>(seq));
      o.sensor_pose().orientation().w(1.0);
      for (std::uint64_t j = 0; j < kPointsEach; ++j) {
        const std::uint64_t i = (seq - 1) * kPointsEach + j;
        fuse_msgs::Point3f pt;
        pt.x(static_cast<float>(i % 20));
        pt.y(static_cast<float>(i / 20));
        pt.z(1.5f);
        o.points().push_back(pt);
      }
      observations.publish(o);
    };
    auto acked = [&] {
      auto s = latest();
      return s && s->session() == kSession ? s->acked_sequence() : 0u;
    };
    const auto end = Clock::now() + 20s;
    while (acked() < kObservations && Clock::now() < end) {  // re-send what stays unacknowledged
      for (std::uint64_t seq = acked() + 1; seq <= kObservations; ++seq) send(seq);
      wait([&] { return acked() >= kObservations; }, 500ms);
    }
    ASSERT_EQ(acked(), kObservations) << read_text(out);
    ASSERT_TRUE(p.signal(SIGTERM));
    const auto exit = p.wait_for(30s);
    ASSERT_TRUE(exit.has_value()) << read_text(out);
    EXPECT_TRUE(exit->success()) << exit->describe() << "\n" << read_text(out);
  }
  EXPECT_NE(read_text(out).find("stopped: map journal closed"), std::string::npos) << read_text(out);
  {
    std::lock_guard<std::mutex> lock(mutex);
    status.reset();
  }
  auto p = launch::Process::spawn(service_argv(map, dir), out);
  ASSERT_TRUE(wait([&] { return latest().has_value(); }, 30s)) << read_text(out);
  EXPECT_EQ(latest()->points(), kObservations * kPointsEach) << read_text(out);
  p.signal(SIGTERM);
  const auto exit = p.wait_for(30s);
  ASSERT_TRUE(exit.has_value());
  EXPECT_TRUE(exit->success()) << exit->describe();
}

// fuse-map on a map directory it cannot write: READY (it serves what it loaded), STATUS says
// degraded, the watchdog keeps being pinged. On a directory another fuse-map holds: no READY,
// exit code 2 (RestartPreventExitStatus=2: not restarted).
TEST(MapServiceNotify, UnwritableDirectoryIsReadyDegradedLockedOneExitsWithTwo) {
  const ServiceCase map{"fuse-map", 86, false};
  const fs::path dir = scratch_dir("notify-map-unwritable");
  std::ofstream(dir / "a_file") << "not a directory";
  auto with_notify = [&](NotifySocket& socket, const fs::path& map_dir, const std::string& out) {
    ScopedEnv env({{"NOTIFY_SOCKET", socket.name()},
                   {"WATCHDOG_USEC", std::to_string(std::chrono::microseconds(kWatchdog).count())}},
                  {"WATCHDOG_PID"});
    std::vector<std::string> argv = service_argv(map, dir);
    argv.back() = map_dir.string();  // --map-dir
    return launch::Process::spawn(argv, out);
  };
  {
    NotifySocket socket((dir / "unwritable.sock").string());
    NotifyLog log(socket);
    const std::string out = (dir / "unwritable.log").string();
    auto p = with_notify(socket, dir / "a_file" / "map", out);
    ASSERT_TRUE(log.wait_for("READY=1", 30s)) << log.dump() << "\n" << read_text(out);
    EXPECT_NE(log.dump().find("STATUS=serving"), std::string::npos) << log.dump();
    EXPECT_NE(log.dump().find("degraded"), std::string::npos) << log.dump();
    const Clock::time_point ready = *log.first("READY=1");
    ASSERT_TRUE(wait_until_count(log, "WATCHDOG=1", ready, 3, 10s)) << log.dump();
    ASSERT_TRUE(p.signal(SIGTERM));
    const auto exit = p.wait_for(30s);
    ASSERT_TRUE(exit.has_value()) << read_text(out);
    EXPECT_TRUE(exit->success()) << exit->describe() << "\n" << read_text(out);
  }
  NotifySocket first_socket((dir / "first.sock").string());
  NotifyLog first_log(first_socket);
  auto first = with_notify(first_socket, dir / "map", (dir / "first.log").string());
  ASSERT_TRUE(first_log.wait_for("READY=1", 30s)) << first_log.dump() << "\n" << read_text(dir / "first.log");
  NotifySocket second_socket((dir / "second.sock").string());
  NotifyLog second_log(second_socket);
  const std::string out = (dir / "second.log").string();
  auto second = with_notify(second_socket, dir / "map", out);
  const auto exit = second.wait_for(30s);
  ASSERT_TRUE(exit.has_value()) << read_text(out);
  EXPECT_FALSE(exit->signaled);
  EXPECT_EQ(exit->code, 2) << read_text(out);
  EXPECT_FALSE(second_log.first("READY=1").has_value()) << second_log.dump();
  EXPECT_TRUE(first.is_running());
  first.signal(SIGTERM);
  EXPECT_TRUE(first.wait_for(30s).has_value());
}

}  // namespace
}  // namespace fuse::deploy_test

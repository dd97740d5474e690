// fuse-map as a process (DESIGN §2): the real binary is spawned; the test publishes observations
// with the typed Publisher and reads map/status, map/chunk and health with Subscribers, as
// fuse-update and a monitor would. fuse-map-ctl is run as a process too.
//
// Observation points lie on a 1 m grid (well above the policy's min_point_distance), each point
// in exactly one observation, so the map must hold exactly the points sent, each once.
// Disk faults are real: a small tmpfs mounted as the map directory (root only, else skipped),
// filled to its last page or remounted read-only.
// DDS domain ids 50..59 belong to this file (59: a domain without a server).
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "../map_storage/tmpfs_mount.hpp"
#include "fuse/map/map_server_core.hpp"
#include "fuse/transport/rpc.hpp"

extern char** environ;

namespace fuse::map_service_test {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;
using Point = std::tuple<float, float, float>;

constexpr std::size_t kPointsPerObservation = 50;

bool wait_until(const std::function<bool()>& done, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() >= end) return done();
    std::this_thread::sleep_for(5ms);
  }
  return true;
}

std::string read_text(const fs::path& file) {
  std::ifstream f(file);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

class TempDir {
 public:
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "fuse-map-service-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }
  std::string str(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

/// A child process (posix_spawn) with stdout and stderr in `log`; SIGKILLed if still running at
/// destruction.
class Process {
 public:
  Process(const std::vector<std::string>& args, const std::string& log) {
    std::vector<std::string> a = args;
    std::vector<char*> argv;
    for (auto& s : a) argv.push_back(s.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
    if (posix_spawn(&pid_, a[0].c_str(), &actions, nullptr, argv.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
  }
  ~Process() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  Process(const Process&) = delete;
  Process& operator=(const Process&) = delete;

  bool started() const { return pid_ > 0; }
  bool running() {
    if (pid_ <= 0) return false;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) != pid_) return true;
    reaped(status);
    return false;
  }
  void signal(int sig) {
    if (pid_ > 0) ::kill(pid_, sig);
  }
  /// Waits for the exit; its exit code, -1 after a signal, -2 when still running at the timeout.
  int wait(std::chrono::milliseconds timeout) {
    wait_until([&] { return !running(); }, timeout);
    return pid_ > 0 ? -2 : code_;
  }

 private:
  void reaped(int status) {
    code_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    pid_ = -1;
  }
  pid_t pid_ = -1;
  int code_ = -2;
};

struct RunResult {
  int code = -2;
  std::string out;
};

/// Runs a command to its end (killed after the timeout); its exit code and stdout + stderr.
RunResult run(const std::vector<std::string>& args, const TempDir& dir, std::chrono::milliseconds timeout = 20s) {
  static int n = 0;
  const std::string log = dir.str("run-" + std::to_string(++n) + ".out");
  Process p(args, log);
  RunResult r;
  r.code = p.wait(timeout);
  r.out = read_text(log);
  return r;
}

/// The value of "name": in fuse-map-ctl's JSON output (numbers and plain strings).
std::string json_field(const std::string& json, const std::string& name) {
  const std::string key = "\"" + name + "\":";
  auto at = json.find(key);
  if (at == std::string::npos) return "<missing " + name + ">";
  at += key.size();
  if (json[at] == '"') return json.substr(at + 1, json.find('"', at + 1) - at - 1);
  return json.substr(at, json.find_first_of(",}", at) - at);
}

/// Point j of observation `sequence`: a 1 m grid over x, y in [-19.5, 19.5] (four 20 m chunks),
/// layers of 0.5 + k m, shifted by `x_offset`.
Point grid_point(std::uint64_t sequence, std::size_t j, float x_offset) {
  const std::size_t i = (sequence - 1) * kPointsPerObservation + j;
  return {x_offset + static_cast<float>(i % 40) - 19.5f, static_cast<float>((i / 40) % 40) - 19.5f,
          static_cast<float>(i / 1600) + 0.5f};
}

fuse_msgs::MapObservation observation(std::uint64_t session, std::uint64_t sequence, float x_offset = 0.0f) {
  fuse_msgs::MapObservation o;
  o.session(session);
  o.sequence_number(sequence);
  o.t(0.1 * static_cast<double>(sequence));
  o.sensor_pose().orientation().w(1.0);
  for (std::size_t j = 0; j < kPointsPerObservation; ++j) {
    const auto [x, y, z] = grid_point(sequence, j, x_offset);
    fuse_msgs::Point3f p;
    p.x(x);
    p.y(y);
    p.z(z);
    o.points().push_back(p);
  }
  return o;
}

/// The points of observations [first, last], each once.
std::map<Point, int> points_of(std::uint64_t first, std::uint64_t last, float x_offset = 0.0f) {
  std::map<Point, int> points;
  for (std::uint64_t s = first; s <= last; ++s) {
    for (std::size_t j = 0; j < kPointsPerObservation; ++j) ++points[grid_point(s, j, x_offset)];
  }
  return points;
}

/// How often fuse-map retries a map directory it cannot write, in these tests.
constexpr const char* kFastRetry = "  retry_interval_s: 0.3\n";

transport::TransportConfig transport_config(int domain) {
  EXPECT_GE(domain, 50);
  EXPECT_LE(domain, 59);
  transport::TransportConfig c;
  c.domain_id = domain;
  return c;
}

/// The test's side of the map server's topics.
class MapClient {
 public:
  explicit MapClient(int domain)
      : participant_(transport::make_participant(transport_config(domain), "map-service-test")),
        observations_(*participant_, transport::topics::kObservation),
        chunks_(*participant_, transport::topics::kMapChunk,
                [this](const fuse_msgs::MapChunk& c) {
                  std::lock_guard<std::mutex> lock(mutex_);
                  received_chunks_[c.key()] = c;
                }),
        status_(*participant_, transport::topics::kMapStatus,
                [this](const fuse_msgs::MapStatus& s) {
                  std::lock_guard<std::mutex> lock(mutex_);
                  if (!first_status_) first_status_ = s;
                  last_status_ = s;
                  ++statuses_;
                  auto& acked = acked_[s.session()];
                  acked = std::max(acked, s.acked_sequence());
                  for (const fuse_msgs::SessionAck& a : s.sessions()) {
                    auto& listed = acked_[a.session()];
                    if (a.acked_sequence() < listed) ++acks_gone_back_;
                    listed = std::max(listed, a.acked_sequence());
                  }
                }),
        health_(*participant_, transport::topics::kHealth, [this](const fuse_msgs::Health& h) {
          if (h.service().to_string() != "fuse-map") return;
          std::lock_guard<std::mutex> lock(mutex_);
          health_samples_.push_back(h);
        }) {}

  transport::Participant& participant() { return *participant_; }

  /// True once fuse-map's observation reader is matched (observations are volatile).
  bool wait_for_server(std::chrono::milliseconds timeout = 15s) {
    return wait_until([&] { return observations_.matched() > 0; }, timeout);
  }
  void publish(const fuse_msgs::MapObservation& o) { ASSERT_TRUE(observations_.publish(o)); }

  /// Highest acknowledged sequence of a session seen on map/status.
  std::uint64_t acked(std::uint64_t session) {
    std::lock_guard<std::mutex> lock(mutex_);
    return acked_[session];
  }
  bool wait_acked(std::uint64_t session, std::uint64_t sequence, std::chrono::milliseconds timeout = 10s) {
    return wait_until([&] { return acked(session) >= sequence; }, timeout);
  }
  /// As fuse-update does: publishes observations [first, last] and re-sends the unacknowledged
  /// ones every 0.5 s (a restarted server's reader may match only after the first send).
  bool send_until_acked(std::uint64_t session, std::uint64_t first, std::uint64_t last,
                        std::chrono::milliseconds timeout = 15s) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      for (std::uint64_t s = std::max(first, acked(session) + 1); s <= last; ++s) publish(observation(session, s));
      if (wait_acked(session, last, 500ms)) return true;
    }
    return false;
  }
  std::optional<fuse_msgs::MapStatus> status() {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_status_;
  }
  /// The first status this client received.
  std::optional<fuse_msgs::MapStatus> first_status() {
    std::lock_guard<std::mutex> lock(mutex_);
    return first_status_;
  }
  /// Times a listed acknowledgement was lower than one seen before (one server, no restart: 0).
  std::size_t acks_gone_back() {
    std::lock_guard<std::mutex> lock(mutex_);
    return acks_gone_back_;
  }
  std::size_t statuses() {
    std::lock_guard<std::mutex> lock(mutex_);
    return statuses_;
  }
  void forget_status() {
    std::lock_guard<std::mutex> lock(mutex_);
    last_status_.reset();
  }

  /// The latest sample of every chunk key.
  std::map<std::uint64_t, fuse_msgs::MapChunk> chunks() {
    std::lock_guard<std::mutex> lock(mutex_);
    return received_chunks_;
  }
  void forget_chunks() {
    std::lock_guard<std::mutex> lock(mutex_);
    received_chunks_.clear();
  }
  /// Every point of the latest chunks, with its number of occurrences.
  std::map<Point, int> map_points() {
    std::map<Point, int> points;
    for (const auto& [key, c] : chunks()) {
      for (const auto& p : c.points()) ++points[{p.x(), p.y(), p.z()}];
    }
    return points;
  }
  std::size_t chunk_point_count() {
    std::size_t n = 0;
    for (const auto& [key, c] : chunks()) n += c.points().size();
    return n;
  }
  /// Waits for a status, then until the chunks received hold as many points as it announces.
  bool wait_map_complete(std::chrono::milliseconds timeout = 10s) {
    return wait_until([&] {
      const auto s = status();
      return s && chunk_point_count() == s->points();
    }, timeout);
  }

  /// A counter of the newest fuse-map heartbeat (0 when absent).
  std::uint64_t counter(const std::string& name) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (health_samples_.empty()) return 0;
    for (const auto& c : health_samples_.back().counters()) {
      if (c.name().to_string() == name) return c.value();
    }
    return 0;
  }
  std::optional<fuse_msgs::Health> health() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (health_samples_.empty()) return std::nullopt;
    return health_samples_.back();
  }

 private:
  std::unique_ptr<transport::Participant> participant_;
  std::mutex mutex_;
  std::map<std::uint64_t, fuse_msgs::MapChunk> received_chunks_;
  std::optional<fuse_msgs::MapStatus> first_status_, last_status_;
  std::size_t statuses_ = 0, acks_gone_back_ = 0;
  std::map<std::uint64_t, std::uint64_t> acked_;
  std::vector<fuse_msgs::Health> health_samples_;
  transport::Publisher<fuse_msgs::MapObservation> observations_;
  transport::Subscriber<fuse_msgs::MapChunk> chunks_;
  transport::Subscriber<fuse_msgs::MapStatus> status_;
  transport::Subscriber<fuse_msgs::Health> health_;
};

/// A config file for fuse-map on `domain` (its map directory is given by --map-dir).
std::string write_config(const TempDir& dir, int domain, const std::string& extra = "") {
  const std::string file = dir.str("system.yaml");
  std::ofstream(file) << "transport:\n  domain_id: " << domain << "\n"
                      << "map_server:\n  directory: " << dir.str("not-this-map") << "\n" << extra
                      << "health:\n  period_s: 0.1\n";
  return file;
}

std::unique_ptr<Process> start_map_server(const TempDir& dir, const std::string& config,
                                          const std::vector<std::string>& more = {}) {
  std::vector<std::string> args{FUSE_MAP_BIN, "--config", config, "--map-dir", dir.str("map")};
  args.insert(args.end(), more.begin(), more.end());
  auto p = std::make_unique<Process>(args, dir.str("fuse-map.log"));
  EXPECT_TRUE(p->started());
  return p;
}

/// fuse-map-ctl with a 10 s deadline (discovery on a loaded machine can take seconds); a later
/// --deadline-ms in args wins.
RunResult ctl(const TempDir& dir, std::vector<std::string> args) {
  args.insert(args.begin(), {FUSE_MAP_CTL_BIN, "--deadline-ms", "10000"});
  return run(args, dir);
}

// ---- observations in, status and chunks out ------------------------------------------------

TEST(MapService, AcknowledgesObservationsAndServesEveryChunkToLateJoiners) {
  TempDir dir;
  auto server = start_map_server(dir, write_config(dir, 50));
  MapClient client(50);
  ASSERT_TRUE(client.wait_for_server()) << read_text(dir.str("fuse-map.log"));
  EXPECT_TRUE(fs::exists(dir.str("map/map.journal"))) << "--map-dir overrides map_server.directory";
  EXPECT_FALSE(fs::exists(dir.str("not-this-map")));

  constexpr std::uint64_t kSession = 7, kCount = 20;
  for (std::uint64_t s = 1; s <= kCount; ++s) client.publish(observation(kSession, s));
  ASSERT_TRUE(client.wait_acked(kSession, kCount)) << read_text(dir.str("fuse-map.log"));
  ASSERT_TRUE(wait_until([&] { return client.chunk_point_count() == kCount * kPointsPerObservation; }, 10s));
  EXPECT_EQ(client.map_points(), points_of(1, kCount));
  ASSERT_TRUE(client.status());
  const auto status = *client.status();
  EXPECT_EQ(status.session(), kSession);
  EXPECT_EQ(status.points(), kCount * kPointsPerObservation);
  EXPECT_EQ(status.chunks(), client.chunks().size());
  EXPECT_EQ(status.observations_applied(), kCount);
  EXPECT_EQ(status.mode().to_string(), "mapping");
  EXPECT_EQ(client.chunks().size(), 4u) << "x, y in [-19.5, 19.5] over 20 m chunks";

  // A late joiner (a new reader) gets the latest sample of every chunk.
  std::mutex mutex;
  std::map<std::uint64_t, fuse_msgs::MapChunk> late;
  transport::Subscriber<fuse_msgs::MapChunk> late_reader(client.participant(), transport::topics::kMapChunk,
                                                         [&](const fuse_msgs::MapChunk& c) {
                                                           std::lock_guard<std::mutex> lock(mutex);
                                                           late[c.key()] = c;
                                                         });
  const auto latest = client.chunks();
  ASSERT_TRUE(wait_until([&] {
    std::lock_guard<std::mutex> lock(mutex);
    return late.size() == latest.size();
  }, 10s));
  std::lock_guard<std::mutex> lock(mutex);
  for (const auto& [key, c] : latest) {
    ASSERT_EQ(late.count(key), 1u);
    EXPECT_EQ(late[key].revision(), c.revision());
    EXPECT_EQ(late[key].points().size(), c.points().size());
    EXPECT_EQ(late[key].epoch(), c.epoch());
  }

  server->signal(SIGTERM);
  EXPECT_EQ(server->wait(10s), 0) << read_text(dir.str("fuse-map.log"));
}

// ---- SIGKILL mid-stream: nothing acknowledged is lost, re-sends are applied once --------------

TEST(MapService, SigkillLosesNothingAcknowledgedAndReSendsApplyOnce) {
  TempDir dir;
  const std::string config = write_config(dir, 51, "  snapshot_every: 15\n");
  auto server = start_map_server(dir, config);
  MapClient client(51);
  ASSERT_TRUE(client.wait_for_server()) << read_text(dir.str("fuse-map.log"));

  constexpr std::uint64_t kSession = 11, kCount = 80;
  for (std::uint64_t s = 1; s <= 40; ++s) {
    client.publish(observation(kSession, s));
    std::this_thread::sleep_for(2ms);
  }
  ASSERT_TRUE(client.wait_acked(kSession, 30)) << read_text(dir.str("fuse-map.log"));
  for (std::uint64_t s = 41; s <= kCount; ++s) client.publish(observation(kSession, s));
  ASSERT_TRUE(client.wait_acked(kSession, 45));
  server->signal(SIGKILL);  // while the burst is being applied
  EXPECT_EQ(server->wait(5s), -1);
  const std::uint64_t acked_before = client.acked(kSession);
  ASSERT_GE(acked_before, 30u);
  RecordProperty("acked_before_kill", static_cast<int>(acked_before));

  client.forget_chunks();
  client.forget_status();
  server = start_map_server(dir, config);
  ASSERT_TRUE(client.wait_map_complete()) << read_text(dir.str("fuse-map.log"));
  const auto after_restart = client.map_points();
  for (const auto& [p, n] : points_of(1, acked_before)) {
    ASSERT_EQ(after_restart.count(p), 1u) << "a point of an acknowledged observation was lost (acked "
                                          << acked_before << ")";
  }
  for (const auto& [p, n] : after_restart) EXPECT_EQ(n, 1) << "a point is in the map twice";

  // The sender re-sends what it has no acknowledgement for, until acknowledged.
  ASSERT_TRUE(client.send_until_acked(kSession, acked_before + 1, kCount)) << read_text(dir.str("fuse-map.log"));
  ASSERT_TRUE(wait_until([&] { return client.chunk_point_count() == kCount * kPointsPerObservation; }, 10s))
      << client.chunk_point_count();
  EXPECT_EQ(client.map_points(), points_of(1, kCount)) << "every observation exactly once";
  ASSERT_TRUE(wait_until([&] { return client.status() && client.status()->observations_applied() == kCount; }, 5s));

  // Re-sent once more: acknowledged again on map/status, applied never.
  const std::size_t statuses = client.statuses();
  const std::uint64_t duplicates = client.counter("observations_duplicate");
  for (std::uint64_t s = 1; s <= kCount; ++s) client.publish(observation(kSession, s));
  ASSERT_TRUE(wait_until([&] { return client.counter("observations_duplicate") >= duplicates + kCount; }, 10s))
      << client.counter("observations_duplicate");
  EXPECT_GT(client.statuses(), statuses);
  EXPECT_EQ(client.acked(kSession), kCount);
  EXPECT_EQ(client.status()->points(), kCount * kPointsPerObservation);
  EXPECT_EQ(client.status()->observations_applied(), kCount);

  server->signal(SIGTERM);
  EXPECT_EQ(server->wait(10s), 0);
}

// ---- fuse-map-ctl: stats, mode, save, load ----------------------------------------------------

TEST(MapService, ControlToolSwitchesModeSavesAndLoads) {
  TempDir dir;
  const std::string config = write_config(dir, 52);
  auto server = start_map_server(dir, config);
  MapClient client(52);
  ASSERT_TRUE(client.wait_for_server()) << read_text(dir.str("fuse-map.log"));
  constexpr std::uint64_t kSession = 3;
  for (std::uint64_t s = 1; s <= 10; ++s) client.publish(observation(kSession, s));
  ASSERT_TRUE(client.wait_acked(kSession, 10));
  const std::string domain = "52";
  // The test's own client for what the tool does not need to show (each tool run discovers anew).
  transport::RpcClient<fuse_msgs::MapControlRequest, fuse_msgs::MapControlReply> rpc(
      client.participant(), transport::services::kMapControl);
  auto control = [&](fuse_msgs::MapCommand command, const std::string& argument) {
    fuse_msgs::MapControlRequest req;
    req.command(command);
    if (command == fuse_msgs::MAP_SET_MODE) req.mode(argument);
    if (command == fuse_msgs::MAP_LOAD || command == fuse_msgs::MAP_SAVE) req.path(argument);
    return rpc.call(req, 10s);
  };

  // Without --config: default transport settings and --domain.
  auto r = ctl(dir, {"--domain", domain, "--json", "stats"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(json_field(r.out, "status"), "ok");
  EXPECT_EQ(json_field(r.out, "points"), "500");
  EXPECT_EQ(json_field(r.out, "mode"), "mapping");
  EXPECT_EQ(json_field(r.out, "acked_sequence"), "10");
  const std::uint64_t epoch = std::stoull(json_field(r.out, "epoch"));

  // Localization: acknowledged, but the map is frozen.
  r = ctl(dir, {"--config", config, "--mode", "localization"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("localization"), std::string::npos) << r.out;
  for (std::uint64_t s = 11; s <= 15; ++s) client.publish(observation(kSession, s));
  ASSERT_TRUE(client.wait_acked(kSession, 15));
  EXPECT_EQ(client.status()->points(), 500u);
  EXPECT_EQ(client.status()->mode().to_string(), "localization");
  auto result = control(fuse_msgs::MAP_STATS, "");
  ASSERT_TRUE(result.ok()) << result.message;
  EXPECT_EQ(result.reply.points(), 500u);
  EXPECT_EQ(result.reply.acked_sequence(), 15u);

  // An unknown mode is the server's bad request (the tool refuses it itself: usage).
  result = control(fuse_msgs::MAP_SET_MODE, "flying");
  EXPECT_EQ(result.status, fuse_msgs::RPC_BAD_REQUEST) << result.message;
  EXPECT_EQ(result.reply.mode().to_string(), "localization");
  EXPECT_EQ(ctl(dir, {"--domain", domain, "--mode", "flying"}).code, 2);

  // Save under a name: into the saved maps (map/saved by default), the path printed.
  r = ctl(dir, {"--domain", domain, "save", "saved.snapshot"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(fs::exists(dir.str("map/saved/saved.snapshot")));
  EXPECT_NE(r.out.find(dir.str("map/saved/saved.snapshot")), std::string::npos) << r.out;

  // Names only: no path reaches the server's file system, whatever lies there (issue: a control
  // request could write /etc or clobber the live journal, and tell which files exist).
  const std::string journal_before = read_text(dir.str("map/map.journal"));
  for (const std::string& bad : {dir.str("outside.snapshot"), std::string("../outside.snapshot"),
                                 std::string("saved/../../outside.snapshot"), std::string(".hidden")}) {
    result = control(fuse_msgs::MAP_SAVE, bad);
    EXPECT_EQ(result.status, fuse_msgs::RPC_BAD_REQUEST) << bad << ": " << result.message;
  }
  EXPECT_FALSE(fs::exists(dir.str("outside.snapshot")));
  EXPECT_FALSE(fs::exists(dir.str("map/outside.snapshot")));
  result = control(fuse_msgs::MAP_SAVE, "map.journal");  // a name, so a saved map: not the live journal
  ASSERT_TRUE(result.ok()) << result.message;
  EXPECT_EQ(result.reply.path().to_string(), dir.str("map/saved/map.journal"));
  EXPECT_EQ(read_text(dir.str("map/map.journal")), journal_before);
  const auto load_existing = control(fuse_msgs::MAP_LOAD, dir.str("map/saved/saved.snapshot"));
  const auto load_missing = control(fuse_msgs::MAP_LOAD, dir.str("map/saved/no-such.snapshot"));
  EXPECT_EQ(load_existing.status, fuse_msgs::RPC_BAD_REQUEST);
  EXPECT_EQ(load_existing.message, load_missing.message) << "no oracle for which files exist";
  EXPECT_EQ(ctl(dir, {"--domain", domain, "save", "../outside.snapshot"}).code, 2) << "the tool refuses a path too";
  EXPECT_EQ(ctl(dir, {"--domain", domain, "load", "/etc/passwd"}).code, 2);
  r = ctl(dir, {"--domain", domain, "--json", "stats"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(json_field(r.out, "epoch"), std::to_string(epoch)) << "nothing refused changed the map";

  // Back to mapping; new points 100 m away make new chunks.
  ASSERT_TRUE(control(fuse_msgs::MAP_SET_MODE, "mapping").ok());
  for (std::uint64_t s = 16; s <= 20; ++s) client.publish(observation(kSession, s, 100.0f));
  ASSERT_TRUE(client.wait_acked(kSession, 20));
  ASSERT_TRUE(wait_until([&] { return client.chunk_point_count() == 750; }, 10s)) << client.chunk_point_count();
  const auto before_load = client.chunks();

  // Load the saved file: the epoch increases, the map is the saved one, chunks it lacks go empty.
  r = ctl(dir, {"--domain", domain, "--json", "load", "saved.snapshot"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(json_field(r.out, "epoch"), std::to_string(epoch + 1));
  EXPECT_EQ(json_field(r.out, "points"), "500");
  ASSERT_TRUE(wait_until([&] {
    const auto chunks = client.chunks();
    if (chunks.size() != before_load.size()) return false;
    for (const auto& [key, c] : chunks) {
      if (c.epoch() != epoch + 1) return false;
    }
    return true;
  }, 10s));
  EXPECT_EQ(client.map_points(), points_of(1, 10));
  std::size_t emptied = 0;
  for (const auto& [key, c] : client.chunks()) emptied += c.points().empty() ? 1 : 0;
  EXPECT_GE(emptied, 1u) << "the chunks 100 m away are gone from the loaded map";
  ASSERT_TRUE(wait_until([&] { return client.status()->epoch() == epoch + 1; }, 5s));

  // Save without a file: a snapshot into the map directory, the journal restarts empty.
  r = ctl(dir, {"--domain", domain, "--json", "save"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(json_field(r.out, "path"), dir.str("map/map.snapshot"));
  EXPECT_EQ(json_field(r.out, "journal_records"), "0");

  // A missing or damaged file: an error reply, the map unchanged.
  r = ctl(dir, {"--domain", domain, "--json", "load", "missing.snapshot"});
  EXPECT_EQ(r.code, 3) << r.out;
  EXPECT_EQ(json_field(r.out, "status"), "bad_request");
  EXPECT_EQ(json_field(r.out, "epoch"), std::to_string(epoch + 1));
  EXPECT_EQ(json_field(r.out, "points"), "500");
  std::ofstream(dir.str("map/saved/garbage.snapshot")) << "not a snapshot at all";
  result = control(fuse_msgs::MAP_LOAD, "garbage.snapshot");
  EXPECT_EQ(result.status, fuse_msgs::RPC_BAD_REQUEST) << result.message;
  EXPECT_EQ(result.reply.epoch(), epoch + 1);
  EXPECT_EQ(result.reply.points(), 500u);

  // Usage errors, and no server on a domain.
  EXPECT_EQ(ctl(dir, {"--domain", domain}).code, 2);
  EXPECT_EQ(ctl(dir, {"--domain", domain, "load"}).code, 2);
  EXPECT_EQ(ctl(dir, {"--domain", "59", "--deadline-ms", "300", "stats"}).code, 4);
  // set-pose (served by fuse-update: none on this domain): four numbers, sigmas and a wait in range.
  EXPECT_EQ(ctl(dir, {"--domain", domain, "set-pose", "1", "2"}).code, 2);
  EXPECT_EQ(ctl(dir, {"--domain", domain, "set-pose", "1", "2", "0", "x"}).code, 2);
  EXPECT_EQ(ctl(dir, {"--domain", domain, "set-pose", "1", "2", "0", "-30", "--std-xy", "0"}).code, 2);
  EXPECT_EQ(ctl(dir, {"--domain", domain, "set-pose", "1", "2", "0", "-30", "--wait", "31"}).code, 2);
  EXPECT_EQ(ctl(dir, {"--domain", domain, "set-pose", "1", "2", "0", "nan"}).code, 2);
  const RunResult no_update = ctl(dir, {"--domain", domain, "--deadline-ms", "300", "set-pose", "1", "-2", "0", "-30", "--wait", "0"});
  EXPECT_EQ(no_update.code, 4) << no_update.out;

  server->signal(SIGTERM);
  EXPECT_EQ(server->wait(10s), 0);
}

// ---- refused observations, malformed samples and a damaged journal ----------------------------

TEST(MapService, RefusesInvalidObservationsAndReportsThemOnHealth) {
  TempDir dir;
  // A journal whose only record is garbage: reported, cut, and the server starts anyway.
  fs::create_directories(dir.str("map"));
  {
    std::ofstream journal(dir.str("map/map.journal"), std::ios::binary);
    // "FUSEMAPJ", version 1, then a record framed as 32 bytes with a CRC that cannot match.
    const std::string bytes = std::string("FUSEMAPJ\x01\x00\x00\x00", 12) + std::string("\x20\x00\x00\x00", 4) +
                              "crc!garbage that is not a record";
    journal.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  auto server = start_map_server(dir, write_config(dir, 53));
  MapClient client(53);
  ASSERT_TRUE(client.wait_for_server()) << read_text(dir.str("fuse-map.log"));

  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto o = observation(0, 1);  // session 0
  client.publish(o);
  o = observation(5, 0);  // sequence 0
  client.publish(o);
  o = observation(5, 1);
  o.t(nan);
  client.publish(o);
  o = observation(5, 1);
  o.sensor_pose().position().y(nan);
  client.publish(o);
  o = observation(5, 1);
  o.sensor_pose().orientation().w(std::numeric_limits<double>::infinity());
  client.publish(o);
  // A sample that does not decode.
  auto raw = client.participant().create_writer(transport::topics::kObservation,
                                                transport::type_support<fuse_msgs::MapObservation>(),
                                                transport::topic_qos(transport::topics::kObservation));
  ASSERT_TRUE(wait_until([&] { return raw->matched_readers() > 0; }, 10s));
  ASSERT_TRUE(raw->write(transport::Bytes{0x00, 0x01, 0x00, 0x00, 0xff, 0xff}));
  // A good one with three points that are not finite.
  o = observation(5, 1);
  for (int i = 0; i < 3; ++i) o.points()[i].x(std::numeric_limits<float>::quiet_NaN());
  client.publish(o);

  ASSERT_TRUE(client.wait_acked(5, 1)) << read_text(dir.str("fuse-map.log"));
  EXPECT_EQ(client.status()->points(), kPointsPerObservation - 3);
  ASSERT_TRUE(wait_until([&] {
    return client.counter("observations_malformed") >= 1 && client.counter("observations_applied") == 1;
  }, 10s)) << read_text(dir.str("fuse-map.log"));
  EXPECT_EQ(client.counter("refused_session_zero"), 1u);
  EXPECT_EQ(client.counter("refused_sequence_zero"), 1u);
  EXPECT_EQ(client.counter("refused_time_not_finite"), 1u);
  EXPECT_EQ(client.counter("refused_pose_not_finite"), 2u);
  EXPECT_EQ(client.counter("observations_refused"), 5u);
  EXPECT_EQ(client.counter("points_not_finite"), 3u);
  EXPECT_GE(client.counter("load_problems"), 1u);
  const auto health = client.health();
  ASSERT_TRUE(health);
  EXPECT_EQ(health->state().to_string(), "running");
  EXPECT_NE(health->last_error().to_string().find("map load"), std::string::npos) << health->last_error().to_string();
  EXPECT_NE(client.status()->last_error().to_string().find("map load"), std::string::npos);
  EXPECT_NE(read_text(dir.str("fuse-map.log")).find("map.journal"), std::string::npos) << "the damage is logged";
  const auto stats = ctl(dir, {"--domain", "53", "--json", "stats"});
  ASSERT_EQ(stats.code, 0) << stats.out;
  EXPECT_EQ(json_field(stats.out, "load_damaged_ranges"), "1");
  EXPECT_EQ(json_field(stats.out, "load_bytes_skipped"), "36") << "the garbage record to the end, frame included";

  EXPECT_TRUE(server->running());
  server->signal(SIGTERM);
  EXPECT_EQ(server->wait(10s), 0);
}

// ---- restart: the acknowledgements as loaded, published at once --------------------------------

TEST(MapService, RestartPublishesEveryRecentSessionsAcknowledgementAtOnce) {
  TempDir dir;
  const std::string config = write_config(dir, 54);
  auto server = start_map_server(dir, config);
  {
    MapClient client(54);
    ASSERT_TRUE(client.wait_for_server()) << read_text(dir.str("fuse-map.log"));
    for (std::uint64_t q = 1; q <= 5; ++q) client.publish(observation(3, q));
    ASSERT_TRUE(client.wait_acked(3, 5));
    for (std::uint64_t q = 1; q <= 7; ++q) client.publish(observation(4, q));
    ASSERT_TRUE(client.wait_acked(4, 7));
    // A session older than this map: its sender holds nothing below 100.
    for (std::uint64_t q = 100; q <= 102; ++q) {
      auto o = observation(5, q);
      o.lowest_unacked(100);
      client.publish(o);
    }
    ASSERT_TRUE(client.wait_acked(5, 102)) << read_text(dir.str("fuse-map.log"));
    server->signal(SIGTERM);
    ASSERT_EQ(server->wait(10s), 0) << read_text(dir.str("fuse-map.log"));
  }
  MapClient client(54);  // listening before the restart: its first status is the start-up one
  server = start_map_server(dir, config);
  ASSERT_TRUE(wait_until([&] { return client.first_status().has_value(); }, 15s)) << read_text(dir.str("fuse-map.log"));
  const fuse_msgs::MapStatus first = *client.first_status();
  EXPECT_EQ(first.session(), 5u) << "the most recently active session";
  EXPECT_EQ(first.acked_sequence(), 102u);
  std::vector<std::pair<std::uint64_t, std::uint64_t>> listed;
  for (const auto& a : first.sessions()) listed.emplace_back(a.session(), a.acked_sequence());
  EXPECT_EQ(listed, (std::vector<std::pair<std::uint64_t, std::uint64_t>>{{5, 102}, {4, 7}, {3, 5}}))
      << "newest first, as loaded, before any observation arrived";

  const auto r = ctl(dir, {"--domain", "54", "--json", "stats"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(json_field(r.out, "state"), "running");
  EXPECT_NE(r.out.find(R"("sessions":[{"session":"0000000000000005","acked_sequence":102},)"), std::string::npos)
      << r.out;
  server->signal(SIGTERM);
  EXPECT_EQ(server->wait(10s), 0);
}

// A saved map another system recorded (issue 16): refused unless asked for, then loaded and logged.
TEST(MapService, AnotherSystemsMapLoadsOnlyWhenAskedFor) {
  TempDir dir;
  {  // vehicle-b's (empty) map, saved among this server's saved maps
    MapServerConfig other;
    other.directory = dir.str("other-map");
    other.system_name = "vehicle-b";
    MapServerCore core(other, MapStorage::Access::kReadWrite);
    fs::create_directories(dir.str("map/saved"));
    core.save(dir.str("map/saved/vehicle-b.snapshot"));
  }
  auto server = start_map_server(dir, write_config(dir, 58));
  MapClient client(58);
  ASSERT_TRUE(client.wait_for_server()) << read_text(dir.str("fuse-map.log"));
  const std::string domain = "58";
  auto r = ctl(dir, {"--domain", domain, "--json", "load", "vehicle-b.snapshot"});
  EXPECT_EQ(r.code, 3) << r.out;
  EXPECT_EQ(json_field(r.out, "status"), "bad_request");
  EXPECT_NE(r.out.find("vehicle-b"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--other-system"), std::string::npos) << r.out;
  EXPECT_EQ(json_field(r.out, "epoch"), "0") << "a refused load changed the map";
  r = ctl(dir, {"--domain", domain, "--json", "load", "vehicle-b.snapshot", "--other-system"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(json_field(r.out, "epoch"), "1");
  // Saved again, the map is this system's now: it loads without the flag.
  ASSERT_EQ(ctl(dir, {"--domain", domain, "save", "mine.snapshot"}).code, 0);
  EXPECT_EQ(ctl(dir, {"--domain", domain, "load", "mine.snapshot"}).code, 0);
  server->signal(SIGTERM);
  EXPECT_EQ(server->wait(10s), 0);
  const std::string log = read_text(dir.str("fuse-map.log"));
  EXPECT_NE(log.find("recorded by system 'vehicle-b'"), std::string::npos) << log;
  EXPECT_NE(log.find("as asked (--other-system)"), std::string::npos) << log;
  // Every control request is logged with who sent it.
  EXPECT_NE(log.find("control: load 'vehicle-b.snapshot' --other-system from fuse-map-ctl: ok"), std::string::npos) << log;
  EXPECT_NE(log.find("control: load 'vehicle-b.snapshot' from fuse-map-ctl: load refused"), std::string::npos) << log;
}

// ---- a map directory that cannot be written: degraded, not down ----------------------------------

/// The persisted map directory read back as an export tool reads it.
std::unique_ptr<MapServerCore> read_back(const fs::path& map_dir) {
  MapServerConfig config;
  config.directory = map_dir.string();
  return std::make_unique<MapServerCore>(config, MapStorage::Access::kReadOnly);
}

std::size_t count_lines(const std::string& text, const std::string& part) {
  std::size_t n = 0;
  for (std::size_t at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++n;
  return n;
}

TEST(MapService, ReadOnlyMapDirectoryAtStartIsServedDegradedAndRecovers) {
  TempDir dir;
  test::TmpfsMount disk(dir.path() / "map", std::size_t{4} << 20);
  if (!disk.ok()) GTEST_SKIP() << disk.why();
  const std::string config = write_config(dir, 55, kFastRetry);
  constexpr std::uint64_t kSession = 7;
  auto server = start_map_server(dir, config);
  {
    MapClient client(55);
    ASSERT_TRUE(client.wait_for_server()) << read_text(dir.str("fuse-map.log"));
    ASSERT_TRUE(client.send_until_acked(kSession, 1, 10));
    server->signal(SIGTERM);
    ASSERT_EQ(server->wait(10s), 0);
  }
  ASSERT_TRUE(disk.set_read_only(true)) << disk.why();

  MapClient client(55);
  server = start_map_server(dir, config);
  ASSERT_TRUE(client.wait_for_server()) << read_text(dir.str("fuse-map.log"));
  // It starts (no exit, no crash loop), serves what it loaded and says why it is degraded.
  ASSERT_TRUE(wait_until([&] { return client.first_status().has_value(); }, 10s));
  EXPECT_EQ(client.first_status()->acked_sequence(), 10u);
  ASSERT_TRUE(wait_until([&] { return client.health() && client.health()->state().to_string() == "degraded"; }, 10s))
      << read_text(dir.str("fuse-map.log"));
  EXPECT_NE(client.health()->last_error().to_string().find("Read-only file system"), std::string::npos)
      << client.health()->last_error().to_string();
  ASSERT_TRUE(client.wait_map_complete());
  EXPECT_EQ(client.map_points(), points_of(1, 10));

  // Nothing new is acknowledged: observations wait in memory.
  for (std::uint64_t q = 11; q <= 20; ++q) client.publish(observation(kSession, q));
  ASSERT_TRUE(wait_until([&] { return client.counter("observations_deferred") >= 10; }, 10s))
      << read_text(dir.str("fuse-map.log"));
  EXPECT_EQ(client.acked(kSession), 10u);
  auto r = ctl(dir, {"--domain", "55", "--json", "stats"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(json_field(r.out, "state"), "degraded");
  EXPECT_NE(json_field(r.out, "state_reason").find("Read-only file system"), std::string::npos) << r.out;
  EXPECT_EQ(json_field(r.out, "pending_observations"), "10");
  EXPECT_TRUE(server->running());

  ASSERT_TRUE(disk.set_read_only(false)) << disk.why();
  ASSERT_TRUE(client.send_until_acked(kSession, 11, 20)) << read_text(dir.str("fuse-map.log"));
  ASSERT_TRUE(wait_until([&] { return client.health()->state().to_string() == "running"; }, 10s));
  ASSERT_TRUE(wait_until([&] { return client.chunk_point_count() == 20 * kPointsPerObservation; }, 10s));
  EXPECT_EQ(client.map_points(), points_of(1, 20));
  EXPECT_EQ(client.acks_gone_back(), 0u);
  server->signal(SIGTERM);
  ASSERT_EQ(server->wait(10s), 0);
  const auto persisted = read_back(dir.path() / "map");
  EXPECT_EQ(persisted->acked(kSession), 20u);
  EXPECT_EQ(persisted->map().num_points(), 20 * kPointsPerObservation);
}

TEST(MapService, FullDiskAndReadOnlyRemountWhileRunningKeepItUpAndLoseNothing) {
  TempDir dir;
  test::TmpfsMount disk(dir.path() / "map", std::size_t{2} << 20);
  if (!disk.ok()) GTEST_SKIP() << disk.why();
  constexpr std::uint64_t kSession = 9;
  auto server = start_map_server(dir, write_config(dir, 56, kFastRetry));
  MapClient client(56);
  ASSERT_TRUE(client.wait_for_server()) << read_text(dir.str("fuse-map.log"));
  ASSERT_TRUE(client.send_until_acked(kSession, 1, 10));

  // Full: degraded, nothing new acknowledged, the observations kept in memory and counted. (The
  // journal's last page may still take the first few.)
  ASSERT_GT(disk.fill(), 0u);
  for (std::uint64_t q = 11; q <= 40; ++q) client.publish(observation(kSession, q));
  const auto handled = [&] { return client.counter("observations_applied") + client.counter("observations_deferred"); };
  ASSERT_TRUE(wait_until([&] { return handled() >= 40; }, 10s)) << read_text(dir.str("fuse-map.log"));
  const std::uint64_t journaled = client.counter("observations_applied");
  ASSERT_LT(journaled, 40u) << "the disk was not full";
  ASSERT_TRUE(wait_until([&] { return client.acked(kSession) == journaled; }, 5s));
  ASSERT_TRUE(wait_until([&] { return client.counter("journal_errors") >= 2; }, 10s)) << "retried, and failed again";
  EXPECT_EQ(client.acked(kSession), journaled) << "nothing acknowledged beyond what was journaled";
  const std::string pending = std::to_string(40 - journaled);
  auto r = ctl(dir, {"--domain", "56", "--json", "stats"});
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(json_field(r.out, "state"), "degraded");
  EXPECT_NE(json_field(r.out, "state_reason").find("No space left on device"), std::string::npos) << r.out;
  EXPECT_EQ(json_field(r.out, "pending_observations"), pending);
  EXPECT_NE(json_field(r.out, "journal_errors"), "0");
  EXPECT_EQ(json_field(r.out, "acked_sequence"), std::to_string(journaled));
  r = ctl(dir, {"--domain", "56", "stats"});
  EXPECT_NE(r.out.find("state     degraded (not journaling: "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("pending   " + pending + " observations"), std::string::npos) << r.out;
  EXPECT_NE(client.status()->last_error().to_string().find("No space left on device"), std::string::npos);

  // Space again: everything journaled, in order, and acknowledged.
  disk.remove();
  ASSERT_TRUE(client.send_until_acked(kSession, 11, 40)) << read_text(dir.str("fuse-map.log"));
  ASSERT_TRUE(wait_until([&] { return client.health()->state().to_string() == "running"; }, 10s));

  // Read-only while running (fuse-map holds no file open for writing between writes).
  ASSERT_TRUE(disk.set_read_only(true)) << disk.why();
  const std::uint64_t deferred = client.counter("observations_deferred");
  for (std::uint64_t q = 41; q <= 50; ++q) client.publish(observation(kSession, q));
  ASSERT_TRUE(wait_until([&] { return client.counter("observations_deferred") >= deferred + 10; }, 10s))
      << read_text(dir.str("fuse-map.log"));
  EXPECT_EQ(client.acked(kSession), 40u);
  ASSERT_TRUE(wait_until([&] { return client.health()->state().to_string() == "degraded"; }, 10s));
  EXPECT_NE(client.health()->last_error().to_string().find("Read-only file system"), std::string::npos);
  ASSERT_TRUE(disk.set_read_only(false)) << disk.why();
  ASSERT_TRUE(client.send_until_acked(kSession, 41, 50)) << read_text(dir.str("fuse-map.log"));
  ASSERT_TRUE(wait_until([&] { return client.health()->state().to_string() == "running"; }, 10s));

  ASSERT_TRUE(wait_until([&] { return client.chunk_point_count() == 50 * kPointsPerObservation; }, 10s));
  EXPECT_EQ(client.map_points(), points_of(1, 50)) << "every observation exactly once";
  EXPECT_EQ(client.acks_gone_back(), 0u);
  EXPECT_TRUE(server->running());
  server->signal(SIGTERM);
  ASSERT_EQ(server->wait(10s), 0);
  // The log says it a few times with counts, not once per observation, re-send or retry.
  const std::string log = read_text(dir.str("fuse-map.log"));
  EXPECT_LE(count_lines(log, "'journal_errors'"), 10u) << log;
  EXPECT_LE(count_lines(log, "'observations_deferred'"), 10u) << log;
  const auto persisted = read_back(dir.path() / "map");
  EXPECT_EQ(persisted->acked(kSession), 50u);
  EXPECT_EQ(persisted->map().num_points(), 50 * kPointsPerObservation);
}

TEST(MapService, SecondServerOnALockedMapDirectoryExitsWithCode2) {
  TempDir dir;
  const std::string config = write_config(dir, 57);
  auto first = start_map_server(dir, config);
  MapClient client(57);
  ASSERT_TRUE(client.wait_for_server()) << read_text(dir.str("fuse-map.log"));
  const std::string log = dir.str("second.log");
  Process second({FUSE_MAP_BIN, "--config", config, "--map-dir", dir.str("map")}, log);
  ASSERT_TRUE(second.started());
  EXPECT_EQ(second.wait(30s), 2) << read_text(log);
  EXPECT_NE(read_text(log).find("another fuse-map"), std::string::npos) << read_text(log);
  EXPECT_TRUE(first->running());
  first->signal(SIGTERM);
  EXPECT_EQ(first->wait(10s), 0);
}

}  // namespace
}  // namespace fuse::map_service_test

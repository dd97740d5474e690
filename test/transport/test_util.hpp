// Helpers of the transport tests: configs on private domain ids, waiting on conditions, and
// every wire type filled with non-default contents (every field, sequences, strings).
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "fuse/transport/msg_traits.hpp"
#include "fuse/transport/rpc.hpp"

extern char** environ;

namespace fuse::transport::test {

using namespace std::chrono_literals;

inline const std::vector<std::string>& vendors() {
  static const std::vector<std::string> v{"fastdds", "cyclonedds"};
  return v;
}

/// Domain ids 10..39 belong to this suite; each test passes its own.
inline TransportConfig config(const std::string& vendor, int domain_id) {
  EXPECT_GE(domain_id, 10);
  EXPECT_LE(domain_id, 39);
  TransportConfig c;
  c.vendor = vendor;
  c.domain_id = domain_id;
  return c;
}

/// Starts this test binary again running only `test` (a DISABLED_ one), with `env` added to the
/// environment and stdout to /dev/null; its pid, or -1 when it could not start.
inline pid_t spawn_this_test(const std::string& test, std::vector<std::string> env) {
  std::vector<char*> envp;
  for (auto& v : env) envp.push_back(v.data());
  for (char** e = environ; *e != nullptr; ++e) envp.push_back(*e);
  envp.push_back(nullptr);
  std::string exe = "/proc/self/exe", filter = "--gtest_filter=" + test, also = "--gtest_also_run_disabled_tests";
  char* argv[] = {exe.data(), filter.data(), also.data(), nullptr};
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  pid_t pid = -1;
  if (posix_spawn(&pid, exe.c_str(), &actions, nullptr, argv, envp.data()) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&actions);
  return pid;
}

template <class Pred>
bool wait_until(Pred pred, std::chrono::milliseconds timeout = 10s) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() >= end) return pred();
    std::this_thread::sleep_for(2ms);
  }
  return true;
}

/// Thread-safe store of the samples a Subscriber received.
template <class T>
class Inbox {
 public:
  void operator()(const T& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    messages_.push_back(msg);
  }
  std::size_t size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return messages_.size();
  }
  std::vector<T> messages() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return messages_;
  }
  bool wait_for(std::size_t n, std::chrono::milliseconds timeout = 10s) const {
    return wait_until([&] { return size() >= n; }, timeout);
  }

 private:
  mutable std::mutex mutex_;
  std::vector<T> messages_;
};

// ---- non-default contents of every type (seed makes samples distinct) ------------------------

inline double v(int seed, int i) { return seed * 1000.0 + i + 0.125; }

inline fuse_msgs::Vector3 vec(int seed, int i) {
  fuse_msgs::Vector3 x;
  x.x(v(seed, i));
  x.y(-v(seed, i + 1));
  x.z(v(seed, i + 2) * 1e-6);
  return x;
}

inline fuse_msgs::Pose pose(int seed, int i) {
  fuse_msgs::Pose p;
  p.position(vec(seed, i));
  fuse_msgs::Quaternion q;
  q.x(0.1 * seed);
  q.y(-0.2);
  q.z(0.3 + i);
  q.w(std::sqrt(2.0));
  p.orientation(q);
  return p;
}

inline fuse_msgs::RpcHeader header(int seed) {
  fuse_msgs::RpcHeader h;
  h.client_id(0xF00D000000000000ull + seed);
  h.request_id(1000 + seed);
  return h;
}

inline fuse_msgs::ImuSample make_imu(int seed) {
  fuse_msgs::ImuSample m;
  m.t(v(seed, 0));
  m.gyro(vec(seed, 1));
  m.accel(vec(seed, 4));
  m.sequence_number(seed + 1);
  m.frame("imu_link_" + std::to_string(seed));
  return m;
}

inline fuse_msgs::LidarScan make_scan(int seed, std::size_t points = 17) {
  fuse_msgs::LidarScan m;
  m.start_time(v(seed, 0));
  m.end_time(v(seed, 1));
  m.sequence_number(seed + 7);
  m.frame("lidar");
  m.points().resize(points);
  for (std::size_t i = 0; i < points; ++i) {
    auto& p = m.points()[i];
    p.x(static_cast<float>(i) * 0.5f + seed);
    p.y(-static_cast<float>(i));
    p.z(0.25f);
    p.intensity(static_cast<float>(i % 256));
    p.time_offset(static_cast<float>(i) * 1e-6f);
    p.ring(static_cast<std::uint16_t>(i % 128));
  }
  return m;
}

inline fuse_msgs::StateEstimate make_state(int seed) {
  fuse_msgs::StateEstimate m;
  m.t(v(seed, 0));
  m.pose(pose(seed, 1));
  m.velocity(vec(seed, 2));
  m.gyro_bias(vec(seed, 3));
  m.accel_bias(vec(seed, 4));
  m.gravity(vec(seed, 5));
  for (std::size_t i = 0; i < m.pose_covariance().size(); ++i) m.pose_covariance()[i] = v(seed, static_cast<int>(i));
  for (std::size_t i = 0; i < m.velocity_covariance().size(); ++i) m.velocity_covariance()[i] = -v(seed, static_cast<int>(i));
  m.status(fuse_msgs::STATUS_CORRECTED);
  m.sequence_number(seed + 3);
  m.frame("world");
  m.child_frame("imu");
  m.angular_velocity(vec(seed, 6));
  m.host_clock_known(true);
  m.host_realtime_offset(v(seed, 7));
  m.host_monotonic_offset(-v(seed, 8));
  m.map_frame(fuse_msgs::MAP_FRAME_SEARCHING);
  m.localization_candidates(static_cast<std::uint32_t>(seed + 2));
  return m;
}

inline fuse_msgs::Correction make_correction(int seed) {
  fuse_msgs::Correction m;
  m.t(v(seed, 0));
  m.scan_sequence(seed + 11);
  m.pose(pose(seed, 1));
  m.velocity(vec(seed, 2));
  m.extrinsic(pose(seed, 3));
  m.gyro_bias(vec(seed, 4));
  m.accel_bias(vec(seed, 5));
  m.gravity(vec(seed, 6));
  m.time_offset(v(seed, 7) * 1e-5);
  for (std::size_t i = 0; i < m.covariance().size(); ++i) m.covariance()[i] = v(seed, static_cast<int>(i));
  m.constraints_kept(1234);
  m.constraints_rejected(56);
  m.iterations(4);
  m.min_eigenvalue_translation(12.5);
  m.min_eigenvalue_rotation(0.75);
  m.min_gamma(0.5);
  m.update_ms(3.25);
  m.converged(true);
  m.result(fuse_msgs::SCAN_PRIOR_ONLY);
  m.map_frame(fuse_msgs::MAP_FRAME_CONFIRMING);
  m.frame_epoch(static_cast<std::uint32_t>(seed + 1));
  m.frame_change(pose(seed, 7));
  m.localization_candidates(3);
  m.localization("searching (ambiguous: 3 candidate(s))");
  return m;
}

inline std::vector<fuse_msgs::Point3f> points3f(int seed, std::size_t n) {
  std::vector<fuse_msgs::Point3f> pts(n);
  for (std::size_t i = 0; i < n; ++i) {
    pts[i].x(static_cast<float>(i) + seed);
    pts[i].y(static_cast<float>(seed) - 0.5f);
    pts[i].z(-static_cast<float>(i) * 0.25f);
  }
  return pts;
}

inline fuse_msgs::MapObservation make_observation(int seed) {
  fuse_msgs::MapObservation m;
  m.session(0xABCDEF0000ull + seed);
  m.sequence_number(seed + 1);
  m.t(v(seed, 0));
  m.sensor_pose(pose(seed, 1));
  m.points(points3f(seed, 23));
  m.lowest_unacked(seed + 1);
  m.gravity(vec(seed, 9));
  return m;
}

inline fuse_msgs::WorldScan make_world_scan(int seed) {
  fuse_msgs::WorldScan m;
  m.t(v(seed, 2));
  m.scan_sequence(seed + 7);
  m.sensor_pose(pose(seed, 3));
  m.points(points3f(seed, 31));
  return m;
}

inline std::vector<fuse_msgs::SessionAck> session_acks(int seed) {
  std::vector<fuse_msgs::SessionAck> acks(3);
  for (std::size_t i = 0; i < acks.size(); ++i) {
    acks[i].session(0xFEEDull + seed + i);
    acks[i].acked_sequence(70 + i);
  }
  return acks;
}

inline fuse_msgs::MapChunk make_chunk(std::uint64_t key, std::uint64_t revision, int seed = 1) {
  fuse_msgs::MapChunk m;
  m.key(key);
  m.epoch(2);
  m.revision(revision);
  m.ix(-3);
  m.iy(4);
  m.iz(-5);
  m.chunk_size(16.0f);
  m.points(points3f(seed, 9));
  return m;
}

inline fuse_msgs::MapStatus make_map_status(int seed) {
  fuse_msgs::MapStatus m;
  m.epoch(seed + 1);
  m.mode("localization");
  m.session(0x1234ull + seed);
  m.acked_sequence(77);
  m.points(123456);
  m.chunks(321);
  m.observations_applied(99);
  m.journal_records(1000);
  m.last_error("disk full? no: seed " + std::to_string(seed));
  m.sessions(session_acks(seed));
  m.gravity(vec(seed, 10));
  return m;
}

inline fuse_msgs::Health make_health(int seed) {
  fuse_msgs::Health m;
  m.service("fuse-state");
  m.instance(0xDEADBEEFull + seed);
  m.sequence_number(seed + 5);
  m.uptime_s(12.5);
  m.state("degraded");
  for (int i = 0; i < 5; ++i) {
    fuse_msgs::Counter c;
    c.name("counter_" + std::to_string(i));
    c.value(static_cast<std::uint64_t>(i * 1000 + seed));
    m.counters().push_back(c);
  }
  m.last_error("imu gap of 0.2 s");
  return m;
}

inline fuse_msgs::QueryRequest make_query_request(int seed) {
  fuse_msgs::QueryRequest m;
  m.header(header(seed));
  m.t(v(seed, 0));
  m.latest(true);
  m.clock(fuse_msgs::CLOCK_HOST_MONOTONIC);
  return m;
}

inline fuse_msgs::QueryReply make_query_reply(int seed) {
  fuse_msgs::QueryReply m;
  m.header(header(seed));
  m.error(fuse_msgs::RPC_NOT_READY);
  m.error_message("imu does not cover t");
  m.estimate(make_state(seed));
  return m;
}

inline fuse_msgs::HistoryRequest make_history_request(int seed) {
  fuse_msgs::HistoryRequest m;
  m.header(header(seed));
  m.t_start(v(seed, 0));
  m.t_end(v(seed, 1));
  return m;
}

inline fuse_msgs::HistoryReply make_history_reply(int seed) {
  fuse_msgs::HistoryReply m;
  m.header(header(seed));
  m.error(fuse_msgs::RPC_OK);
  m.error_message("");
  m.initialised(true);
  m.last_correction_time(v(seed, 9));
  for (int i = 0; i < 4; ++i) {
    fuse_msgs::HistoryEntry e;
    e.t(v(seed, i));
    e.pose(pose(seed, i));
    e.velocity(vec(seed, i + 1));
    e.extrinsic(pose(seed, i + 2));
    e.gyro_bias(vec(seed, i + 3));
    e.accel_bias(vec(seed, i + 4));
    e.gravity(vec(seed, i + 5));
    e.time_offset(v(seed, i + 40) * 1e-5);
    e.gyro(vec(seed, i + 6));
    e.accel(vec(seed, i + 7));
    if (i == 2) {  // an entry with a step (a coasted gap): its sequence and levelling travel too
      for (int k = 0; k < 24; ++k) e.step_q().push_back(v(seed, i + 8 + k));
      e.step_level_accel(vec(seed, i + 31));
      e.step_level_sigma(v(seed, i + 32));
      e.step_coast_from(v(seed, i + 33));
      e.step_coast_accel_std(v(seed, i + 34));
      e.step_coast_gyro_std(v(seed, i + 35));
      e.coasting(true);
    }
    m.entries().push_back(e);
  }
  for (std::size_t i = 0; i < m.covariance().size(); ++i) m.covariance()[i] = v(seed, static_cast<int>(i));
  m.map_frame(fuse_msgs::MAP_FRAME_LOCALIZED);
  m.frame_epoch(static_cast<std::uint32_t>(seed + 4));
  return m;
}

inline fuse_msgs::MapControlRequest make_map_control_request(int seed) {
  fuse_msgs::MapControlRequest m;
  m.header(header(seed));
  m.command(fuse_msgs::MAP_LOAD);
  m.mode("mapping");
  m.path("maps/site_" + std::to_string(seed) + ".fmap");
  return m;
}

inline fuse_msgs::MapControlReply make_map_control_reply(int seed) {
  fuse_msgs::MapControlReply m;
  m.header(header(seed));
  m.error(fuse_msgs::RPC_BAD_REQUEST);
  m.error_message("unknown mode");
  m.mode("mapping");
  m.epoch(3);
  m.points(999);
  m.chunks(12);
  m.acked_sequence(41);
  m.journal_records(8);
  m.path("maps/out.fmap");
  m.state("degraded");
  m.state_reason("map directory not writable: Read-only file system");
  m.journal_errors(2);
  m.pending_observations(17);
  m.pending_bytes(204800);
  m.pending_dropped(1);
  m.load_bytes_skipped(64);
  m.load_damaged_ranges(1);
  m.load_observations_lost(1);
  m.load_chunks_lost(0);
  m.sessions(session_acks(seed));
  return m;
}

inline fuse_msgs::SetPoseRequest make_set_pose_request(int seed) {
  fuse_msgs::SetPoseRequest m;
  m.header(header(seed));
  m.position(vec(seed, 1));
  m.yaw(v(seed, 2));
  m.std_xy(1.5);
  m.std_yaw(0.25);
  m.wait_s(5.0);
  m.t(v(seed, 3));
  return m;
}

inline fuse_msgs::SetPoseReply make_set_pose_reply(int seed) {
  fuse_msgs::SetPoseReply m;
  m.header(header(seed));
  m.error(fuse_msgs::RPC_OK);
  m.error_message("");
  m.result(fuse_msgs::SET_POSE_CORRECTED);
  m.position(vec(seed, 3));
  m.yaw(v(seed, 4));
  m.offset(0.75);
  m.turn(-0.125);
  m.detail("confirmed 0.75 m from the pose given");
  return m;
}

/// One filled sample of each type, and the topic it travels on in the tests.
template <class T>
struct Sample;
#define FUSE_TEST_SAMPLE(T, topic, maker)                    \
  template <>                                                \
  struct Sample<fuse_msgs::T> {                              \
    static std::string topic_name() { return topic; }        \
    static fuse_msgs::T make(int seed) { return maker(seed); } \
  };
FUSE_TEST_SAMPLE(ImuSample, topics::kImu, make_imu)
FUSE_TEST_SAMPLE(LidarScan, topics::kLidarScan, [](int s) { return make_scan(s); })
FUSE_TEST_SAMPLE(StateEstimate, topics::kCorrected, make_state)
FUSE_TEST_SAMPLE(Correction, topics::kCorrection, make_correction)
FUSE_TEST_SAMPLE(MapObservation, topics::kObservation, make_observation)
FUSE_TEST_SAMPLE(WorldScan, topics::kWorldScan, make_world_scan)
FUSE_TEST_SAMPLE(MapChunk, topics::kMapChunk, [](int s) { return make_chunk(100 + s, 1, s); })
FUSE_TEST_SAMPLE(MapStatus, topics::kMapStatus, make_map_status)
FUSE_TEST_SAMPLE(Health, topics::kHealth, make_health)
FUSE_TEST_SAMPLE(QueryRequest, request_topic(services::kQuery), make_query_request)
FUSE_TEST_SAMPLE(QueryReply, reply_topic(services::kQuery), make_query_reply)
FUSE_TEST_SAMPLE(HistoryRequest, request_topic(services::kHistory), make_history_request)
FUSE_TEST_SAMPLE(HistoryReply, reply_topic(services::kHistory), make_history_reply)
FUSE_TEST_SAMPLE(MapControlRequest, request_topic(services::kMapControl), make_map_control_request)
FUSE_TEST_SAMPLE(MapControlReply, reply_topic(services::kMapControl), make_map_control_reply)
FUSE_TEST_SAMPLE(SetPoseRequest, request_topic(services::kSetPose), make_set_pose_request)
FUSE_TEST_SAMPLE(SetPoseReply, reply_topic(services::kSetPose), make_set_pose_reply)
#undef FUSE_TEST_SAMPLE

/// Calls f(T{}) for every type in msg_traits.hpp.
template <class F>
void for_each_type(F&& f) {
  f(fuse_msgs::ImuSample{});
  f(fuse_msgs::LidarScan{});
  f(fuse_msgs::StateEstimate{});
  f(fuse_msgs::Correction{});
  f(fuse_msgs::MapObservation{});
  f(fuse_msgs::WorldScan{});
  f(fuse_msgs::MapChunk{});
  f(fuse_msgs::MapStatus{});
  f(fuse_msgs::Health{});
  f(fuse_msgs::QueryRequest{});
  f(fuse_msgs::QueryReply{});
  f(fuse_msgs::HistoryRequest{});
  f(fuse_msgs::HistoryReply{});
  f(fuse_msgs::MapControlRequest{});
  f(fuse_msgs::MapControlReply{});
  f(fuse_msgs::SetPoseRequest{});
  f(fuse_msgs::SetPoseReply{});
}

}  // namespace fuse::transport::test

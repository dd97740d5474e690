// FUSE query client: asks the running estimator (fuse-state's `query` service) for the state
// at a time. This header is the whole installed API of the fuse_query library and includes only
// the standard library: no DDS, Fast CDR, Eigen or generated wire types reach the caller.
//
//   fuse::query::ClientOptions options;
//   options.domain_id = 7;
//   fuse::query::Client client(options);
//   client.wait_for_server(2000);
//   const fuse::query::Result r = client.at(t);  // or client.at(unix_time, Clock::host_realtime)
//   if (r.ok()) {
//     steer_by(r.estimate.position, r.estimate.orientation_xyzw);  // tracking, t in the history
//   } else {
//     hold(r.error, r.message);  // e.g. out_of_range "t=... is before the history [a, b]"
//   }
//
//   // Or streamed: every estimate fuse-state publishes (one per IMU sample), no RPC.
//   client.subscribe([](const fuse::query::Result& r) { if (r.ok()) control(r.estimate); });
//   const fuse::query::Result newest = client.newest();  // or poll the newest one
#pragma once

#include <array>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#if defined(__GNUC__)
#define FUSE_QUERY_API __attribute__((visibility("default")))
#else
#define FUSE_QUERY_API
#endif

namespace fuse::query {

/// How to reach the estimator: the same transport settings as the services' `transport:`
/// config section, plus the reply deadline.
struct ClientOptions {
  std::string vendor = "fastdds";  ///< fastdds | cyclonedds
  int domain_id = 0;               ///< DDS domain, 0..101
  int deadline_ms = 1000;          ///< per call: no reply by then gives Error::unavailable
  bool loopback_only = true;       ///< discovery by unicast on 127.0.0.1 only
  int max_participants = 32;       ///< participants reachable on loopback, 4..120
  bool shared_memory = false;      ///< Fast DDS shared-memory transport
  std::size_t socket_buffer_bytes = 4u << 20;  ///< UDP send/receive buffers
  std::string participant_name = "fuse-query";
  /// Scheduler slice (microseconds) requested for the client's own transport threads, which
  /// receive the replies and wake the caller: 100..100000, or 0 for the kernel's default. A
  /// short slice lets them preempt a CPU-bound thread when a reply arrives instead of waiting
  /// up to the default slice (1.4 ms on two CPUs). Needs Linux 6.12 or later (EEVDF); ignored
  /// by older kernels. The caller's own threads are left as they are.
  int scheduler_slice_us = 100;
  /// transport.system_name of the system to ask: its DDS partition (empty: the default one).
  std::string system_name;
  /// DDS Security (transport.security): join the secured bus as `security_identity` (empty:
  /// participant_name) with its certificate and grant from the keystore made by fuse-keystore;
  /// the planner role may call query and read odometry.
  bool security = false;
  std::string security_keystore;
  std::string security_identity;
  std::string security_private_key;  ///< empty: <keystore>/identities/<identity>/key.pem
  /// Across computers (loopback_only false): transport.interfaces and transport.peers, IPv4
  /// addresses (this computer's interfaces; the system's computers for unicast discovery).
  std::vector<std::string> interfaces;
  std::vector<std::string> peers;
};

/// Only `ok` means: a pose to steer by (the estimator tracks, t lies in its history, the
/// orientation is a unit quaternion). Every other value has a message saying why; for
/// `out_of_range` and `not_tracking` the estimate is filled too (status, and the best guess).
enum class Error {
  ok,
  bad_request,   ///< the request is invalid (non-finite, negative or absurd time); not sent
  not_ready,     ///< valid, but the estimator cannot answer yet (not initialised, IMU not there)
  unavailable,   ///< no reply before the deadline (no server, or it is busy)
  internal,      ///< the server failed while answering, or its reply was not a valid estimate
  /// t lies outside the history (status too_old or in_future); the message names the covered
  /// interval. Ask again for a time inside it.
  out_of_range,
  /// The estimator is relocalizing or lost (status says which; message why): the pose in the
  /// estimate is its best guess, not one to steer by.
  not_tracking,
};

enum class Status {
  not_initialised,  ///< the estimator has no state yet
  interpolated,     ///< t lies in the history, up to (and at) the last LiDAR correction
  propagated,       ///< t lies past the last correction: IMU propagation only
  too_old,          ///< t is older than the history holds
  in_future,        ///< t is newer than the latest IMU sample
  /// The estimator's own state, whatever t: its prior is uncertain (after a restart, a data gap
  /// or a clock step) and scans are being re-localised against the map. The pose is the best
  /// guess so far; do not steer by it.
  relocalizing,
  /// The estimator has no usable estimate (nothing to recover from, re-localisation keeps
  /// failing, or no LiDAR correction for a while although data arrives). It keeps trying.
  lost,
};

/// The clock a time is on.
enum class Clock {
  sensor,          ///< the sensor clock every estimate is stamped on (Estimate::t)
  host_realtime,   ///< the host's CLOCK_REALTIME (UNIX time, seconds)
  host_monotonic,  ///< the host's CLOCK_MONOTONIC (seconds); only on fuse-state's own machine
};

/// Host clock minus sensor clock, as fuse-state measures it from the arrival of the IMU samples:
/// the fastest sample of the last 10 s, so the mapping is late by at most that sample's latency
/// (driver, ingestion and transport; typically well under a millisecond on one machine).
struct HostClock {
  bool known = false;             ///< false until fuse-state has received an IMU sample
  double realtime_offset = 0.0;   ///< t_realtime = t_sensor + realtime_offset
  double monotonic_offset = 0.0;  ///< t_monotonic = t_sensor + monotonic_offset
};

/// The state of the IMU body in the world frame at time t.
struct Estimate {
  double t = 0.0;                                ///< seconds, sensor clock
  std::array<double, 3> position{};              ///< metres, world frame
  std::array<double, 4> orientation_xyzw{0.0, 0.0, 0.0, 1.0};  ///< rotation world <- IMU
  std::array<double, 3> velocity{};              ///< m/s, world frame
  /// rad/s, IMU (body) frame: the gyro sample held at t minus the estimated gyro bias.
  std::array<double, 3> angular_velocity{};
  /// Row-major 6x6: position (x, y, z) then rotation (rx, ry, rz) as a right perturbation.
  std::array<double, 36> pose_covariance{};
  std::array<double, 9> velocity_covariance{};   ///< row-major 3x3, world frame
  Status status = Status::not_initialised;
  HostClock host_clock;                          ///< t on the host: t + host_clock.*_offset
  std::string frame_id = "world";                ///< the frame of position, orientation, velocity
  std::string child_frame_id = "imu";            ///< the body they describe (T_world_imu)
};

struct Result {
  Error error = Error::unavailable;
  std::string message;  ///< why, when error != ok
  Estimate estimate;    ///< meaningful when ok(); status and best guess for out_of_range, not_tracking
  bool ok() const { return error == Error::ok; }
};

/// A connection to the query service. Calls are thread-safe and block at most deadline_ms.
/// A moved-from Client may only be destroyed or assigned to.
class FUSE_QUERY_API Client {
 public:
  /// Joins the DDS domain. Throws std::invalid_argument on bad options (unknown vendor, domain
  /// outside 0..101, deadline <= 0, max_participants outside 4..120, socket buffers outside
  /// 64 KiB..256 MiB, scheduler slice outside 100..100000 and not 0) and std::runtime_error
  /// when the transport cannot start.
  explicit Client(const ClientOptions& options = {});
  ~Client();
  Client(Client&&) noexcept;
  Client& operator=(Client&&) noexcept;
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  /// The estimate at time t (seconds on `clock`). A host time is mapped to the sensor clock by
  /// fuse-state (not_ready before it has a mapping); the estimate's t is on the sensor clock.
  Result at(double t, Clock clock = Clock::sensor);
  /// The newest estimate the server holds.
  Result latest();

  /// Streaming, for planners that do not poll by RPC: `callback` gets every estimate fuse-state
  /// publishes (one per IMU sample, best effort: a late one is not re-sent), judged as at()
  /// judges a reply (ok() only for a tracked pose). It runs on a transport thread: keep it short.
  /// Replaces an earlier callback; an empty one stops the calls (the subscription stays).
  void subscribe(std::function<void(const Result&)> callback);
  /// The newest streamed estimate, judged as at() judges a reply; not_ready before the first one
  /// arrived. The first call subscribes (so the first answer is usually not_ready).
  Result newest();
  /// Waits until a query server is matched; false when none appeared within timeout_ms.
  bool wait_for_server(int timeout_ms);

  const ClientOptions& options() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

/// Largest time accepted (seconds, about the year 2286): later times are refused as absurd.
inline constexpr double kMaxQueryTime = 1e10;

FUSE_QUERY_API const char* to_string(Error error);
FUSE_QUERY_API const char* to_string(Status status);

}  // namespace fuse::query

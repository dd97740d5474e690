// A stand-in for fuse-state's query service: an RpcServer<QueryRequest, QueryReply> answering
// known estimates, statuses and typed errors by request time, counting what it handled.
#pragma once

#include <atomic>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "fuse/transport/rpc.hpp"
#include "fuse/transport/typed.hpp"

namespace fuse::test {

/// Times the stand-in server answers specially; every other time gets an interpolated estimate.
namespace query_times {
inline constexpr double kInterpolated = 100.0;
inline constexpr double kCorrected = 101.0;
inline constexpr double kTooOld = 1.0;
inline constexpr double kInFuture = 200.0;
inline constexpr double kNotInitialised = 0.0;
inline constexpr double kRelocalizing = 102.0;
inline constexpr double kLost = 103.0;
inline constexpr double kNotReady = 50.0;
inline constexpr double kThrows = 51.0;
inline constexpr double kServerRefuses = 52.0;
inline constexpr double kLatest = 105.5;  ///< the time of the latest estimate
/// The host clock mapping every estimate carries (t_host = t + offset).
inline constexpr double kRealtimeOffset = 1.7e9;
inline constexpr double kMonotonicOffset = 5000.25;
}  // namespace query_times

/// The estimate the server answers for time t: every field derived from t, so a test can
/// recompute it.
inline fuse_msgs::StateEstimate known_estimate(double t, fuse_msgs::EstimateStatus status) {
  fuse_msgs::StateEstimate e;
  e.t(t);
  fuse_msgs::Pose pose;
  pose.position().x(t + 1.0);
  pose.position().y(-2.5);
  pose.position().z(0.125);
  pose.orientation().x(0.0);
  pose.orientation().y(0.0);
  pose.orientation().z(std::sin(0.25));
  pose.orientation().w(std::cos(0.25));
  e.pose(pose);
  e.velocity().x(0.5);
  e.velocity().y(-0.25);
  e.velocity().z(t / 1000.0);
  for (int i = 0; i < 36; ++i) e.pose_covariance()[i] = (i % 7 == 0) ? 0.0625 * (i / 7 + 1) : 1e-6 * i;
  for (int i = 0; i < 9; ++i) e.velocity_covariance()[i] = (i % 4 == 0) ? 0.5 * (i / 4 + 1) : -1e-7 * i;
  e.status(status);
  e.sequence_number(static_cast<unsigned long long>(t));
  e.frame("world");
  e.child_frame("imu");
  e.angular_velocity().x(t / 100.0);
  e.angular_velocity().y(-0.5);
  e.angular_velocity().z(0.25);
  e.host_clock_known(true);
  e.host_realtime_offset(query_times::kRealtimeOffset);
  e.host_monotonic_offset(query_times::kMonotonicOffset);
  return e;
}

class FakeQueryServer {
 public:
  explicit FakeQueryServer(int domain_id) {
    transport::TransportConfig config;
    config.domain_id = domain_id;
    participant_ = transport::make_participant(config, "fake-fuse-state");
    server_ = std::make_unique<Server>(*participant_, transport::services::kQuery,
                                       [this](const fuse_msgs::QueryRequest& q, fuse_msgs::QueryReply& r) { answer(q, r); });
    odometry_ = std::make_unique<transport::Publisher<fuse_msgs::StateEstimate>>(*participant_, transport::topics::kOdometry);
  }
  ~FakeQueryServer() {
    odometry_.reset();
    server_.reset();
    participant_.reset();
  }

  /// Publishes the known estimate for t on state/odometry, as fuse-state does per IMU sample.
  void stream(double t, fuse_msgs::EstimateStatus status) { odometry_->publish(known_estimate(t, status)); }

  /// Requests for a time no client should send (non-finite, negative, beyond 1e10 s). Tests
  /// in other processes may call this server too, but never with such a time.
  int invalid_requests() const { return invalid_requests_; }

 private:
  using Server = transport::RpcServer<fuse_msgs::QueryRequest, fuse_msgs::QueryReply>;

  void answer(const fuse_msgs::QueryRequest& q, fuse_msgs::QueryReply& r) {
    namespace qt = query_times;
    if (!q.latest() && !(q.t() >= 0.0 && q.t() <= 1e10)) ++invalid_requests_;
    if (q.latest()) {
      r.estimate(known_estimate(qt::kLatest, fuse_msgs::STATUS_PROPAGATED));
      return;
    }
    double t = q.t();  // on the sensor clock, as fuse-state maps a host time
    if (q.clock() == fuse_msgs::CLOCK_HOST_REALTIME) t -= qt::kRealtimeOffset;
    if (q.clock() == fuse_msgs::CLOCK_HOST_MONOTONIC) t -= qt::kMonotonicOffset;
    if (t == qt::kNotReady) {
      r.error(fuse_msgs::RPC_NOT_READY);
      r.error_message("IMU does not cover t yet");
    } else if (t == qt::kThrows) {
      throw std::runtime_error("boom in the handler");
    } else if (t == qt::kServerRefuses) {
      r.error(fuse_msgs::RPC_BAD_REQUEST);
      r.error_message("refused by the server");
    } else {
      r.estimate(known_estimate(t, status_of(t)));
    }
  }

  static fuse_msgs::EstimateStatus status_of(double t) {
    namespace qt = query_times;
    if (t == qt::kCorrected) return fuse_msgs::STATUS_CORRECTED;
    if (t == qt::kTooOld) return fuse_msgs::STATUS_TOO_OLD;
    if (t == qt::kInFuture) return fuse_msgs::STATUS_IN_FUTURE;
    if (t == qt::kNotInitialised) return fuse_msgs::STATUS_NOT_INITIALISED;
    if (t == qt::kRelocalizing) return fuse_msgs::STATUS_RELOCALIZING;
    if (t == qt::kLost) return fuse_msgs::STATUS_LOST;
    return fuse_msgs::STATUS_INTERPOLATED;
  }

  std::unique_ptr<transport::Participant> participant_;
  std::unique_ptr<Server> server_;
  std::unique_ptr<transport::Publisher<fuse_msgs::StateEstimate>> odometry_;
  std::atomic<int> invalid_requests_{0};
};

}  // namespace fuse::test

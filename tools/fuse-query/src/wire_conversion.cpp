#include "wire_conversion.hpp"

#include <cmath>

namespace fuse::query {

namespace {
/// A quaternion farther than this from unit norm was not a rotation on the server.
constexpr double kUnitTolerance = 1e-6;
/// Closer than this to unit norm is rounding: left exactly as sent.
constexpr double kRoundingTolerance = 1e-12;
}  // namespace

Error to_error(fuse_msgs::RpcStatus status) {
  switch (status) {
    case fuse_msgs::RPC_OK: return Error::ok;
    case fuse_msgs::RPC_BAD_REQUEST: return Error::bad_request;
    case fuse_msgs::RPC_NOT_READY: return Error::not_ready;
    case fuse_msgs::RPC_UNAVAILABLE: return Error::unavailable;
    case fuse_msgs::RPC_INTERNAL_ERROR: return Error::internal;
  }
  return Error::internal;  // a value this client does not know
}

Status to_status(fuse_msgs::EstimateStatus status) {
  switch (status) {
    case fuse_msgs::STATUS_NOT_INITIALISED: return Status::not_initialised;
    // A time exactly at a correction lies in the corrected history as well.
    case fuse_msgs::STATUS_INTERPOLATED:
    case fuse_msgs::STATUS_CORRECTED: return Status::interpolated;
    case fuse_msgs::STATUS_PROPAGATED: return Status::propagated;
    case fuse_msgs::STATUS_TOO_OLD: return Status::too_old;
    case fuse_msgs::STATUS_IN_FUTURE: return Status::in_future;
    case fuse_msgs::STATUS_RELOCALIZING: return Status::relocalizing;
    case fuse_msgs::STATUS_LOST: return Status::lost;
  }
  return Status::not_initialised;
}

Estimate to_estimate(const fuse_msgs::StateEstimate& msg) {
  Estimate e;
  e.t = msg.t();
  const auto& p = msg.pose().position();
  const auto& q = msg.pose().orientation();
  const auto& v = msg.velocity();
  e.position = {p.x(), p.y(), p.z()};
  e.orientation_xyzw = {q.x(), q.y(), q.z(), q.w()};
  e.velocity = {v.x(), v.y(), v.z()};
  const auto& w = msg.angular_velocity();
  e.angular_velocity = {w.x(), w.y(), w.z()};
  e.pose_covariance = msg.pose_covariance();
  e.velocity_covariance = msg.velocity_covariance();
  e.status = to_status(msg.status());
  e.host_clock.known = msg.host_clock_known();
  e.host_clock.realtime_offset = msg.host_realtime_offset();
  e.host_clock.monotonic_offset = msg.host_monotonic_offset();
  if (msg.frame().size() > 0) e.frame_id = msg.frame().to_string();
  if (msg.child_frame().size() > 0) e.child_frame_id = msg.child_frame().to_string();
  return e;
}

Result to_result(fuse_msgs::RpcStatus status, const std::string& message, const fuse_msgs::QueryReply& reply) {
  Result r;
  r.error = to_error(status);
  r.message = message;
  if (r.error != Error::ok) return r;
  return judged(to_estimate(reply.estimate()), message);
}

Result to_result(const fuse_msgs::StateEstimate& streamed) { return judged(to_estimate(streamed), ""); }

Result judged(const Estimate& estimate, const std::string& message) {
  Result r;
  r.error = Error::ok;
  r.message = message;
  r.estimate = estimate;
  // The server answered; whether the answer is a pose to steer by is the status's to say.
  switch (r.estimate.status) {
    case Status::interpolated:
    case Status::propagated: break;
    case Status::too_old:
    case Status::in_future:
      r.error = Error::out_of_range;
      if (r.message.empty()) {
        r.message = std::string("t is ") +
                    (r.estimate.status == Status::too_old ? "older than the history" : "newer than the latest IMU sample");
      }
      return r;
    case Status::relocalizing:
    case Status::lost:
      r.error = Error::not_tracking;
      if (r.message.empty()) r.message = std::string("the estimator is ") + to_string(r.estimate.status);
      return r;
    case Status::not_initialised:
      r.error = Error::not_ready;
      if (r.message.empty()) r.message = "the estimator is not initialised";
      return r;
  }
  // A pose to steer by has a unit quaternion (normalised against rounding on the wire).
  auto& q = r.estimate.orientation_xyzw;
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!std::isfinite(n) || std::abs(n - 1.0) > kUnitTolerance) {
    r.error = Error::internal;
    r.message = "the server's orientation is not a unit quaternion (norm " + std::to_string(n) + ")";
    return r;
  }
  if (std::abs(n - 1.0) > kRoundingTolerance) {
    for (double& c : q) c /= n;
  }
  r.message.clear();
  return r;
}

}  // namespace fuse::query

#include "wire_conversion.hpp"

namespace fuse::query {

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
  e.pose_covariance = msg.pose_covariance();
  e.velocity_covariance = msg.velocity_covariance();
  e.status = to_status(msg.status());
  return e;
}

Result to_result(fuse_msgs::RpcStatus status, const std::string& message, const fuse_msgs::QueryReply& reply) {
  Result r;
  r.error = to_error(status);
  r.message = message;
  if (r.error == Error::ok) r.estimate = to_estimate(reply.estimate());
  return r;
}

}  // namespace fuse::query

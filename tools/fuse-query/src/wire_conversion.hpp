// Conversion between the query service's wire types (fuse_msgs) and the client's public types.
#pragma once

#include <string>

#include "fuse/query/client.hpp"
#include "fuse_msgs.h"

namespace fuse::query {

Error to_error(fuse_msgs::RpcStatus status);
Status to_status(fuse_msgs::EstimateStatus status);
Estimate to_estimate(const fuse_msgs::StateEstimate& msg);

/// The result of one call: the RPC status and message, and the estimate when the call succeeded;
/// an answer outside the history, or while the estimator does not track, is not Error::ok.
Result to_result(fuse_msgs::RpcStatus status, const std::string& message, const fuse_msgs::QueryReply& reply);
/// A streamed estimate (state/odometry), judged as a reply is.
Result to_result(const fuse_msgs::StateEstimate& streamed);
/// An answered estimate: ok() only for a tracked pose with a unit quaternion; otherwise the error
/// its status means, with `message` or a default one.
Result judged(const Estimate& estimate, const std::string& message);

}  // namespace fuse::query

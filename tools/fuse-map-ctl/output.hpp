// What fuse-map-ctl prints: the reply as aligned text, or as one JSON object.
#pragma once

#include <string>

#include "fuse_msgs.h"

namespace fuse::map_ctl {

/// "ok", "bad_request", "not_ready", "unavailable", "internal_error".
std::string status_name(fuse_msgs::RpcStatus status);

/// The map's state after the command, one "name value" line per field (path when there is one).
std::string format_text(const fuse_msgs::MapControlReply& reply);

/// One JSON object: command, status, message and the reply's fields.
std::string format_json(const std::string& command, fuse_msgs::RpcStatus status, const std::string& message,
                        const fuse_msgs::MapControlReply& reply);

/// set-pose: "accepted" | "corrected" | "refused" | "pending".
std::string result_name(fuse_msgs::SetPoseResult result);
/// The set-pose verdict, one "name value" line per field.
std::string format_text(const fuse_msgs::SetPoseReply& reply);
std::string format_json(fuse_msgs::RpcStatus status, const std::string& message, const fuse_msgs::SetPoseReply& reply);

}  // namespace fuse::map_ctl

// What fuse-query prints: a short text block, or one JSON object.
#pragma once

#include <string>

#include "fuse/query/client.hpp"

namespace fuse::query_tool {

/// "key: values" lines: t, status, position, orientation_xyzw, velocity and the diagonals of
/// the pose and velocity covariances.
std::string format_text(const query::Result& result);

/// One JSON object: error and message always; on success also t, status, position,
/// orientation_xyzw, velocity, both covariance diagonals and both full (row-major) covariances.
/// Non-finite numbers are written as null.
std::string format_json(const query::Result& result);

}  // namespace fuse::query_tool

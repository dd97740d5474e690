// Writes a map's points as a point cloud file (binary PCD v0.7 or binary little-endian PLY 1.0,
// x y z float32), with a header comment naming the frame. Written directly (the formats' headers
// are a few lines), so the tool needs no PCL; the tests read the files back with PCL.
#pragma once

#include <cstddef>
#include <string>

#include "fuse/map/point_map.hpp"

namespace fuse::map_export {

enum class CloudFormat { kPcd, kPly };

/// The header comment of every exported file: what the coordinates are.
inline constexpr const char* kFrameComment =
    "frame: world (FUSE map frame, metres; the frame of fuse-state's poses T_world_imu)";

/// Writes every point of map (chunk by chunk) to file; returns the number of points written.
/// Throws std::runtime_error naming the path when the file cannot be written (nothing is left
/// at file then).
std::size_t write_cloud(const PointMap& map, CloudFormat format, const std::string& file);

}  // namespace fuse::map_export

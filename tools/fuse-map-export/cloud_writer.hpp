// Writes a map's points as a point cloud file through PCL (PCD or PLY, binary). PCL stays in
// cloud_writer.cpp.
#pragma once

#include <cstddef>
#include <string>

#include "fuse/map/point_map.hpp"

namespace fuse::map_export {

enum class CloudFormat { kPcd, kPly };

/// Writes every point of map (chunk by chunk) to file; returns the number of points written.
/// Throws std::runtime_error when PCL cannot write the file.
std::size_t write_cloud(const PointMap& map, CloudFormat format, const std::string& file);

}  // namespace fuse::map_export

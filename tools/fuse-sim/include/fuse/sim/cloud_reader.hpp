// Reads a point cloud as tools/fuse-map-export writes it: binary little-endian PLY 1.0 with one
// vertex element, or binary PCD v0.7, whose x y z are float32 (other fields and properties of a
// fixed size are skipped; x y z may also be float64). Every part of the header and the body's size
// is checked; anything else is refused with a CloudReadError naming the file and what is wrong.
#pragma once

#include <Eigen/Core>
#include <stdexcept>
#include <string>
#include <vector>

namespace fuse::sim {

/// An unreadable or malformed point cloud file (fuse-sim exits 4).
class CloudReadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The points of a PLY or PCD file (told apart by the first line: "ply" or a PCD header line).
std::vector<Eigen::Vector3f> read_cloud(const std::string& file);

}  // namespace fuse::sim

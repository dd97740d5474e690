#include "cloud_writer.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <vector>

namespace fuse::map_export {

namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the binary PCD / PLY bodies are written little-endian");

/// The header of a binary PCD v0.7 file (x y z float32), its first comment naming the frame.
std::string pcd_header(std::size_t n) {
  const std::string count = std::to_string(n);
  return "# .PCD v0.7 - Point Cloud Data file format\n"
         "# " + std::string(kFrameComment) + "\n"
         "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
         "WIDTH " + count + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + count + "\nDATA binary\n";
}

/// The header of a binary little-endian PLY 1.0 file with one vertex element (x y z float32).
std::string ply_header(std::size_t n) {
  return "ply\nformat binary_little_endian 1.0\ncomment " + std::string(kFrameComment) +
         "\nelement vertex " + std::to_string(n) + "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
}

}  // namespace

std::size_t write_cloud(const PointMap& map, CloudFormat format, const std::string& file) {
  std::vector<float> xyz;
  xyz.reserve(3 * map.num_points());
  map.for_each_chunk([&](const PointChunk& chunk) {
    for (const Eigen::Vector3f& p : chunk.points) xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
  });
  const std::size_t n = xyz.size() / 3;
  const std::string header = format == CloudFormat::kPcd ? pcd_header(n) : ply_header(n);
  // Written beside the target and renamed over it: a failed export leaves no half file.
  const std::string partial = file + ".partial";
  {
    std::ofstream out(partial, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error("cannot create " + partial + ": " + std::strerror(errno));
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
    out.write(reinterpret_cast<const char*>(xyz.data()), static_cast<std::streamsize>(xyz.size() * sizeof(float)));
    out.flush();
    if (!out) {
      const std::string why = std::strerror(errno);
      std::filesystem::remove(partial);
      throw std::runtime_error("cannot write " + partial + ": " + why);
    }
  }
  std::error_code ec;
  std::filesystem::rename(partial, file, ec);
  if (ec) {
    std::filesystem::remove(partial);
    throw std::runtime_error("cannot rename " + partial + " to " + file + ": " + ec.message());
  }
  return n;
}

}  // namespace fuse::map_export

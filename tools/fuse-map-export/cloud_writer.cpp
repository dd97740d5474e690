#include "cloud_writer.hpp"

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <stdexcept>

namespace fuse::map_export {

std::size_t write_cloud(const PointMap& map, CloudFormat format, const std::string& file) {
  pcl::PointCloud<pcl::PointXYZ> cloud;
  cloud.reserve(map.num_points());
  map.for_each_chunk([&](const PointChunk& chunk) {
    for (const Eigen::Vector3f& p : chunk.points) cloud.push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  });
  cloud.width = static_cast<std::uint32_t>(cloud.size());
  cloud.height = 1;
  cloud.is_dense = true;
  const int rc = format == CloudFormat::kPcd ? pcl::io::savePCDFileBinary(file, cloud)
                                             : pcl::io::savePLYFile(file, cloud, /*binary_mode=*/true);
  if (rc != 0) throw std::runtime_error("cannot write " + file + " (PCL error " + std::to_string(rc) + ")");
  return cloud.size();
}

}  // namespace fuse::map_export

#include "fuse/association/spatial_index.hpp"

#include "fuse/association/ivox.hpp"
#include "fuse/association/kdtree_index.hpp"
#include "fuse/association/voxel_grid_index.hpp"

#include <cmath>

namespace fuse {

void SpatialIndexConfig::load(ConfigNode& node) {
  node.get("type", type).get("voxel_size", voxel_size).get("neighborhood", neighborhood);
  node.get("max_voxels", max_voxels).get("max_points_per_voxel", max_points_per_voxel);
  node.check(type == "ivox" || type == "kdtree" || type == "voxel_grid", "type",
             "unknown spatial index '" + type + "' (known: ivox, kdtree, voxel_grid)");
  node.check(std::isfinite(voxel_size) && voxel_size >= 0.05 && voxel_size <= 10.0, "voxel_size", "must be in [0.05, 10] m");
  node.check(neighborhood == "center" || neighborhood == "nearby6" || neighborhood == "nearby18" ||
                 neighborhood == "nearby26",
             "neighborhood", "must be one of center, nearby6, nearby18, nearby26");
  node.check(max_voxels >= 1000, "max_voxels", "must be at least 1000");
  node.check(max_points_per_voxel >= 1, "max_points_per_voxel", "must be at least 1");
  node.finish();
}

std::unique_ptr<SpatialIndex> make_spatial_index(const SpatialIndexConfig& config) {
  if (config.type == "ivox") return std::make_unique<IVox>(config);
  if (config.type == "kdtree") return std::make_unique<KdTreeIndex>(config);
  if (config.type == "voxel_grid") return std::make_unique<VoxelGridIndex>(config);
  throw ConfigError("spatial_index.type: unknown spatial index '" + config.type +
                    "' (known: ivox, kdtree, voxel_grid)");
}

}  // namespace fuse

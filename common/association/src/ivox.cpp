#include "fuse/association/ivox.hpp"

#include <algorithm>
#include <cmath>

namespace fuse {

namespace {
std::vector<Eigen::Vector3i> neighborhood_offsets(const std::string& name) {
  std::vector<Eigen::Vector3i> out{Eigen::Vector3i::Zero()};
  for (int x = -1; x <= 1; ++x) {
    for (int y = -1; y <= 1; ++y) {
      for (int z = -1; z <= 1; ++z) {
        const int manhattan = std::abs(x) + std::abs(y) + std::abs(z);
        if (manhattan == 0) continue;
        if ((name == "nearby6" && manhattan == 1) || (name == "nearby18" && manhattan <= 2) || name == "nearby26") {
          out.emplace_back(x, y, z);
        }
      }
    }
  }
  return out;
}
}  // namespace

IVox::IVox(const SpatialIndexConfig& config)
    : config_(config), inv_voxel_size_(static_cast<float>(1.0 / config.voxel_size)),
      offsets_(neighborhood_offsets(config.neighborhood)) {
  table_.reserve(std::min<std::size_t>(config.max_voxels, 1u << 20));
}

IVox::Key IVox::key_of(const Eigen::Vector3f& p) const {
  return Key(static_cast<int>(std::floor(p.x() * inv_voxel_size_)), static_cast<int>(std::floor(p.y() * inv_voxel_size_)),
             static_cast<int>(std::floor(p.z() * inv_voxel_size_)));
}

void IVox::insert(const std::vector<Eigen::Vector3f>& world_points) {
  for (const Eigen::Vector3f& p : world_points) {
    const Key key = key_of(p);
    auto it = table_.find(key);
    if (it == table_.end()) {
      voxels_.push_front(Voxel{key, {}});
      voxels_.front().points.reserve(8);
      it = table_.emplace(key, voxels_.begin()).first;
      if (voxels_.size() > config_.max_voxels) {  // LRU eviction of the least recently touched voxel
        num_points_ -= voxels_.back().points.size();
        table_.erase(voxels_.back().key);
        voxels_.pop_back();
      }
    } else {
      voxels_.splice(voxels_.begin(), voxels_, it->second);  // touched: move to the front
    }
    auto& points = it->second->points;
    if (points.size() < config_.max_points_per_voxel) {
      points.push_back(p);
      ++num_points_;
    }
  }
}

void IVox::knn(const Eigen::Vector3f& q, int k, float max_dist, Neighbors& out) const {
  k = std::min(k, Neighbors::kMaxK);
  out.count = 0;
  const float max_d2 = max_dist * max_dist;
  const Key center = key_of(q);
  // Keep the k best in a small sorted array (insertion sort: k ≤ 16).
  for (const Key& offset : offsets_) {
    const auto it = table_.find(center + offset);
    if (it == table_.end()) continue;
    for (const Eigen::Vector3f& p : it->second->points) {
      const float d2 = (p - q).squaredNorm();
      if (d2 > max_d2 || (out.count == k && d2 >= out.dist2[k - 1])) continue;
      int pos = out.count < k ? out.count++ : k - 1;
      while (pos > 0 && out.dist2[pos - 1] > d2) {
        out.dist2[pos] = out.dist2[pos - 1];
        out.points[pos] = out.points[pos - 1];
        --pos;
      }
      out.dist2[pos] = d2;
      out.points[pos] = p;
    }
  }
}

void IVox::trim(const Eigen::Vector3f& center, float half_extent) {
  for (auto it = voxels_.begin(); it != voxels_.end();) {
    auto& pts = it->points;
    pts.erase(std::remove_if(pts.begin(), pts.end(),
                             [&](const Eigen::Vector3f& p) { return ((p - center).cwiseAbs().array() > half_extent).any(); }),
              pts.end());
    if (pts.empty()) {
      table_.erase(it->key);
      it = voxels_.erase(it);
    } else {
      ++it;
    }
  }
  num_points_ = 0;
  for (const auto& v : voxels_) num_points_ += v.points.size();
}

void IVox::for_each_point(const std::function<void(const Eigen::Vector3f&)>& fn) const {
  for (const auto& v : voxels_) {
    for (const auto& p : v.points) fn(p);
  }
}

}  // namespace fuse

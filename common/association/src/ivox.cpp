#include "fuse/association/ivox.hpp"

#include <algorithm>
#include <cmath>

namespace fuse {

namespace {
constexpr std::size_t kInitialSlots = 1u << 12;
/// The table grows when more than this fraction of its slots are used (linear probing stays short).
constexpr double kMaxLoad = 0.5;
/// Eviction removes this fraction of max_voxels at once, so its cost is amortised over many inserts.
constexpr double kEvictFraction = 0.1;

std::vector<Eigen::Vector3i> neighborhood_offsets(const std::string& name) {
  std::vector<Eigen::Vector3i> out;
  for (int x = -1; x <= 1; ++x) {
    for (int y = -1; y <= 1; ++y) {
      for (int z = -1; z <= 1; ++z) {
        const int manhattan = std::abs(x) + std::abs(y) + std::abs(z);
        if (manhattan == 0 || (name == "nearby6" && manhattan == 1) || (name == "nearby18" && manhattan <= 2) ||
            name == "nearby26") {
          out.emplace_back(x, y, z);
        }
      }
    }
  }
  // Nearest voxels first (centre, faces, edges, corners): the k-th distance bound then prunes more.
  std::stable_sort(out.begin(), out.end(),
                   [](const Eigen::Vector3i& a, const Eigen::Vector3i& b) { return a.cwiseAbs().sum() < b.cwiseAbs().sum(); });
  return out;
}

std::uint64_t hash_key(const Eigen::Vector3i& k) {
  // Pack the three coordinates, then the splitmix64 finaliser spreads them over the table.
  std::uint64_t h = (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.x())) * 0x9E3779B97F4A7C15ULL) ^
                    (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.y())) << 21) ^
                    (static_cast<std::uint64_t>(static_cast<std::uint32_t>(k.z())) << 42);
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ULL;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebULL;
  return h ^ (h >> 31);
}
}  // namespace

IVox::IVox(const SpatialIndexConfig& config)
    : config_(config), voxel_size_(static_cast<float>(config.voxel_size)),
      inv_voxel_size_(static_cast<float>(1.0 / config.voxel_size)), offsets_(neighborhood_offsets(config.neighborhood)),
      slots_(kInitialSlots) {}

IVox::Key IVox::key_of(const Eigen::Vector3f& p) const {
  return Key(static_cast<int>(std::floor(p.x() * inv_voxel_size_)), static_cast<int>(std::floor(p.y() * inv_voxel_size_)),
             static_cast<int>(std::floor(p.z() * inv_voxel_size_)));
}

std::size_t IVox::slot_of(const Key& key) const {
  const std::size_t mask = slots_.size() - 1;
  std::size_t i = hash_key(key) & mask;
  while (slots_[i].voxel >= 0 && slots_[i].key != key) i = (i + 1) & mask;
  return i;
}

std::int32_t IVox::find(const Key& key) const { return slots_[slot_of(key)].voxel; }

void IVox::rebuild_table(std::size_t capacity) {
  slots_.assign(capacity, Slot{});
  for (std::size_t v = 0; v < voxels_.size(); ++v) {
    if (voxels_[v].points.empty()) continue;
    slots_[slot_of(voxels_[v].key)] = Slot{voxels_[v].key, static_cast<std::int32_t>(v)};
  }
}

void IVox::evict_least_recent() {
  // Evict the kEvictFraction least recently touched voxels (nth_element on their touch times).
  std::vector<std::pair<std::uint64_t, std::int32_t>> touches;
  touches.reserve(num_voxels_);
  for (std::size_t v = 0; v < voxels_.size(); ++v) {
    if (!voxels_[v].points.empty()) touches.emplace_back(voxels_[v].last_touch, static_cast<std::int32_t>(v));
  }
  const std::size_t n_evict = std::max<std::size_t>(1, static_cast<std::size_t>(kEvictFraction * config_.max_voxels));
  const std::size_t n = std::min(n_evict, touches.size());
  std::nth_element(touches.begin(), touches.begin() + static_cast<std::ptrdiff_t>(n - 1), touches.end());
  for (std::size_t i = 0; i < n; ++i) {
    Voxel& vox = voxels_[touches[i].second];
    num_points_ -= vox.points.size();
    std::vector<Eigen::Vector3f>().swap(vox.points);
    free_voxels_.push_back(touches[i].second);
    --num_voxels_;
  }
  rebuild_table(slots_.size());
}

void IVox::insert(const std::vector<Eigen::Vector3f>& world_points) {
  ++clock_;
  for (const Eigen::Vector3f& p : world_points) {
    const Key key = key_of(p);
    std::size_t s = slot_of(key);
    std::int32_t v = slots_[s].voxel;
    if (v < 0) {
      if (num_voxels_ >= config_.max_voxels) {
        evict_least_recent();
        s = slot_of(key);
      }
      if (free_voxels_.empty()) {
        v = static_cast<std::int32_t>(voxels_.size());
        voxels_.emplace_back();
      } else {
        v = free_voxels_.back();
        free_voxels_.pop_back();
      }
      voxels_[v].key = key;
      voxels_[v].points.reserve(8);
      slots_[s] = Slot{key, v};
      ++num_voxels_;
    }
    Voxel& vox = voxels_[v];
    vox.last_touch = clock_;
    if (vox.points.size() < config_.max_points_per_voxel) {
      vox.points.push_back(p);
      ++num_points_;
    }
    // Grow only now: rebuild_table() skips voxel records without points, so a voxel created by
    // this point must hold it first (else the next point of its key would create a duplicate).
    if (static_cast<double>(num_voxels_) > kMaxLoad * static_cast<double>(slots_.size())) {
      rebuild_table(slots_.size() * 2);
    }
  }
}

void IVox::knn(const Eigen::Vector3f& q, int k, float max_dist, Neighbors& out) const {
  k = std::min(k, Neighbors::kMaxK);
  out.count = 0;
  float bound2 = max_dist * max_dist;  // squared radius that can still improve the result
  const Key center = key_of(q);
  const Eigen::Vector3f center_min = center.cast<float>() * voxel_size_;
  for (const Key& offset : offsets_) {
    // Skip a voxel whose box is farther from q than the current k-th neighbour (or max_dist).
    const Eigen::Vector3f box_min = center_min + offset.cast<float>() * voxel_size_;
    const Eigen::Vector3f gap =
        (box_min - q).cwiseMax(q - box_min - Eigen::Vector3f::Constant(voxel_size_)).cwiseMax(0.0f);
    if (gap.squaredNorm() > bound2) continue;
    const std::int32_t v = find(center + offset);
    if (v < 0) continue;
    // Keep the k best in a small sorted array (insertion sort: k ≤ 16).
    for (const Eigen::Vector3f& p : voxels_[v].points) {
      const float d2 = (p - q).squaredNorm();
      if (d2 > bound2) continue;
      int pos = out.count < k ? out.count++ : k - 1;
      while (pos > 0 && out.dist2[pos - 1] > d2) {
        out.dist2[pos] = out.dist2[pos - 1];
        out.points[pos] = out.points[pos - 1];
        --pos;
      }
      out.dist2[pos] = d2;
      out.points[pos] = p;
      if (out.count == k) bound2 = out.dist2[k - 1];
    }
  }
}

void IVox::trim(const Eigen::Vector3f& center, float half_extent) {
  num_points_ = 0;
  for (std::size_t v = 0; v < voxels_.size(); ++v) {
    auto& pts = voxels_[v].points;
    if (pts.empty()) continue;
    pts.erase(std::remove_if(pts.begin(), pts.end(),
                             [&](const Eigen::Vector3f& p) { return ((p - center).cwiseAbs().array() > half_extent).any(); }),
              pts.end());
    if (pts.empty()) {
      std::vector<Eigen::Vector3f>().swap(pts);
      free_voxels_.push_back(static_cast<std::int32_t>(v));
      --num_voxels_;
    }
    num_points_ += pts.size();
  }
  rebuild_table(slots_.size());
}

void IVox::for_each_point(const std::function<void(const Eigen::Vector3f&)>& fn) const {
  for (const auto& v : voxels_) {
    for (const auto& p : v.points) fn(p);
  }
}

}  // namespace fuse

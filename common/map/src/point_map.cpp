#include "fuse/map/point_map.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace fuse {

namespace {
constexpr std::uint64_t kCoordMask = (std::uint64_t{1} << PointMap::kCoordBits) - 1;

bool coord_in_range(std::int64_t c) { return c >= PointMap::kCoordMin && c <= PointMap::kCoordMax; }

/// Chunk coordinate of one axis, in 64 bits so that far points can be range-checked.
std::int64_t axis_coord(float v, double inv_chunk_size) {
  return static_cast<std::int64_t>(std::floor(static_cast<double>(v) * inv_chunk_size));
}
}  // namespace

PointMap::PointMap(double chunk_size) : chunk_size_(chunk_size), inv_chunk_size_(1.0 / chunk_size) {
  if (!(std::isfinite(chunk_size) && chunk_size > 0.0)) {
    throw std::invalid_argument("PointMap: chunk_size must be > 0, got " + std::to_string(chunk_size));
  }
}

std::uint64_t PointMap::pack_key(const Eigen::Vector3i& coord) {
  for (int i = 0; i < 3; ++i) {
    if (!coord_in_range(coord[i])) {
      throw std::out_of_range("PointMap: chunk coordinate " + std::to_string(coord[i]) + " outside [" +
                              std::to_string(kCoordMin) + ", " + std::to_string(kCoordMax) + "]");
    }
  }
  const auto biased = [](std::int32_t c) { return static_cast<std::uint64_t>(static_cast<std::int64_t>(c) + kCoordBias); };
  return biased(coord.x()) << (2 * kCoordBits) | biased(coord.y()) << kCoordBits | biased(coord.z());
}

Eigen::Vector3i PointMap::unpack_key(std::uint64_t key) {
  const auto unbiased = [](std::uint64_t bits) {
    return static_cast<std::int32_t>(static_cast<std::int64_t>(bits & kCoordMask) - kCoordBias);
  };
  return Eigen::Vector3i(unbiased(key >> (2 * kCoordBits)), unbiased(key >> kCoordBits), unbiased(key));
}

Eigen::Vector3i PointMap::coord_of(const Eigen::Vector3f& p) const {
  return Eigen::Vector3i(static_cast<int>(axis_coord(p.x(), inv_chunk_size_)),
                         static_cast<int>(axis_coord(p.y(), inv_chunk_size_)),
                         static_cast<int>(axis_coord(p.z(), inv_chunk_size_)));
}

bool PointMap::insertable(const Eigen::Vector3f& p) const {
  if (!p.allFinite()) return false;
  for (int i = 0; i < 3; ++i) {
    // Compare in double first: floor of a huge value would overflow the 64-bit cast.
    const double c = std::floor(static_cast<double>(p[i]) * inv_chunk_size_);
    if (c < kCoordMin || c > kCoordMax) return false;
  }
  return true;
}

std::vector<std::uint64_t> PointMap::insert(const std::vector<Eigen::Vector3f>& points) {
  std::vector<std::uint64_t> changed;
  // Points of a scan arrive spatially coherent: remember the last chunk to skip most lookups.
  PointChunk* last = nullptr;
  for (const Eigen::Vector3f& p : points) {
    if (!insertable(p)) continue;
    const Eigen::Vector3i coord = coord_of(p);
    if (last == nullptr || last->coord != coord) {
      const std::uint64_t key = pack_key(coord);
      auto [it, created] = chunks_.try_emplace(key);
      last = &it->second;
      if (created) {
        last->key = key;
        last->coord = coord;
      }
      changed.push_back(key);
    }
    last->points.push_back(p);
    ++num_points_;
  }
  std::sort(changed.begin(), changed.end());
  changed.erase(std::unique(changed.begin(), changed.end()), changed.end());
  for (std::uint64_t key : changed) ++chunks_[key].revision;
  return changed;
}

bool PointMap::put_chunk(PointChunk chunk) {
  for (int i = 0; i < 3; ++i) {
    if (!coord_in_range(chunk.coord[i])) return false;
  }
  if (pack_key(chunk.coord) != chunk.key) return false;
  for (const Eigen::Vector3f& p : chunk.points) {
    if (!insertable(p) || coord_of(p) != chunk.coord) return false;
  }
  auto it = chunks_.find(chunk.key);
  if (it != chunks_.end()) num_points_ -= it->second.points.size();
  num_points_ += chunk.points.size();
  const std::uint64_t key = chunk.key;
  chunks_[key] = std::move(chunk);
  return true;
}

const PointChunk* PointMap::chunk(std::uint64_t key) const {
  auto it = chunks_.find(key);
  return it == chunks_.end() ? nullptr : &it->second;
}

void PointMap::for_each_chunk(const std::function<void(const PointChunk&)>& fn) const {
  for (const auto& [key, chunk] : chunks_) fn(chunk);
}

void PointMap::clear() {
  chunks_.clear();
  num_points_ = 0;
}

}  // namespace fuse

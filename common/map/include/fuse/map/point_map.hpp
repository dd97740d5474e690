// The persistent map (DESIGN §2, fuse-map): world-frame points in cubic chunks of edge
// `chunk_size`. A chunk is the unit the map server stores (one snapshot record) and publishes
// (one keyed `map/chunk` sample); its revision increases with every change, so a replica keeps
// the newest.
//
// Chunk key: the integer chunk coordinates (ix, iy, iz) = floor(p / chunk_size), each biased by
// 2^20 into 21 unsigned bits (offset binary, so negatives pack without sign extension), packed as
//     key = (ix + 2^20) << 42 | (iy + 2^20) << 21 | (iz + 2^20)      (bit 63 always 0).
// Coordinates in [-2^20, 2^20 - 1] are representable: ±20 971 km at 20 m chunks. Points outside
// that range, or not finite, are refused (insertable() is false; insert() skips them).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <vector>

namespace fuse {

struct PointChunk {
  std::uint64_t key = 0;
  Eigen::Vector3i coord = Eigen::Vector3i::Zero();  ///< (ix, iy, iz)
  std::uint64_t revision = 0;                       ///< 1 after the first insert, +1 per change
  std::vector<Eigen::Vector3f> points;              ///< in insertion order
};

class PointMap {
 public:
  static constexpr int kCoordBits = 21;
  static constexpr std::int32_t kCoordBias = 1 << (kCoordBits - 1);
  static constexpr std::int32_t kCoordMin = -kCoordBias;
  static constexpr std::int32_t kCoordMax = kCoordBias - 1;

  /// chunk_size in metres, > 0 (throws std::invalid_argument otherwise).
  explicit PointMap(double chunk_size = 20.0);

  /// Packs chunk coordinates (each in [kCoordMin, kCoordMax], else std::out_of_range) into a key.
  static std::uint64_t pack_key(const Eigen::Vector3i& coord);
  static Eigen::Vector3i unpack_key(std::uint64_t key);

  /// Chunk coordinates of a point (floor of p / chunk_size; meaningful when insertable(p)).
  Eigen::Vector3i coord_of(const Eigen::Vector3f& p) const;
  /// True when p is finite and its chunk coordinates are representable in a key.
  bool insertable(const Eigen::Vector3f& p) const;

  /// Appends the points to their chunks (creating chunks as needed); each changed chunk's revision
  /// increases by one. Returns the keys of the changed chunks, ascending. Skips points that are not
  /// insertable().
  std::vector<std::uint64_t> insert(const std::vector<Eigen::Vector3f>& points);

  /// Replaces (or creates) one chunk as stored: used when loading a snapshot. The key must match
  /// coord; returns false (and changes nothing) otherwise or when a point lies outside the chunk.
  bool put_chunk(PointChunk chunk);

  const PointChunk* chunk(std::uint64_t key) const;
  /// Visits the chunks in ascending key order.
  void for_each_chunk(const std::function<void(const PointChunk&)>& fn) const;

  std::size_t num_points() const { return num_points_; }
  std::size_t num_chunks() const { return chunks_.size(); }
  double chunk_size() const { return chunk_size_; }
  void clear();

 private:
  double chunk_size_;
  double inv_chunk_size_;
  std::map<std::uint64_t, PointChunk> chunks_;
  std::size_t num_points_ = 0;
};

}  // namespace fuse

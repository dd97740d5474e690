// The map server's logic without transport (DESIGN §2, fuse-map): the persistent PointMap, an
// iVox index over the same points for the policy's nearest-neighbour tests, the mapping policy
// and the files (MapStorage). The service wraps it in DDS: observations in, changed chunks and
// status out, control requests (mode, save, load, stats).
//
// Observation rules, per session (one fuse-update instance), with sequences 1, 2, ...:
//   - a sequence at or below the highest acknowledged one is a duplicate (a re-send): it is
//     acknowledged again and nothing else happens;
//   - mapping: the observation is journaled (fsync'd) first, then applied through the policy; it
//     is acknowledged only once journaled, so an acknowledged observation survives any crash;
//   - localization: the map is frozen; the observation is acknowledged but neither journaled nor
//     applied (it would not change the map). Such acknowledgements live in memory only: after a
//     restart the acknowledged sequence of a session is the highest one applied to the map.
// Restart: snapshot + journal replay rebuild the same map, point for point, and the same
// acknowledged sequences. The start-up mode is the configured one (`policy.mode`); the mode in
// a snapshot records the mode when it was written.
// Replacing the map (load) keeps every session's acknowledged sequence (acknowledgements never go
// back), increases the epoch, and is made durable at once by a snapshot into the map directory.
//
// Not thread-safe: the service serialises calls.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "fuse/association/spatial_index.hpp"
#include "fuse/core/config.hpp"
#include "fuse/map/map_policy.hpp"
#include "fuse/map/map_storage.hpp"
#include "fuse/map/point_map.hpp"

namespace fuse {

struct MapServerConfig {
  /// iVox capacity of the server's index: the persistent map must never be evicted.
  static constexpr std::size_t kNoEviction = 2147483647;  // iVox voxel indices are 32-bit

  std::string directory = "map";     ///< map.snapshot and map.journal live here (created if missing)
  double chunk_size = 20.0;          ///< m, of a new map (a snapshot keeps its own)
  std::size_t snapshot_every = 500;  ///< journaled observations between automatic snapshots; 0: only on save
  bool fsync = true;                 ///< false only for benches: acknowledged data may then be lost
  MapPolicyConfig policy;            ///< policy.mode is the mode at start-up
  /// The policy's nearest-neighbour index over the map's points. A restart rebuilds the same map
  /// when the index holds every point: it never evicts (max_voxels), and max_points_per_voxel
  /// should stay above what min_point_distance lets into one voxel (64 > (0.5/0.25 + 1)^3 by default).
  SpatialIndexConfig index = default_index();

  static SpatialIndexConfig default_index();
  void load(ConfigNode& node);
};

struct MapApplyResult {
  bool duplicate = false;  ///< already acknowledged: nothing done
  bool applied = false;    ///< journaled and offered to the policy (mapping mode)
  std::size_t inserted = 0;
  std::size_t rejected = 0;  ///< points not finite or outside the chunk key range, dropped
  std::vector<std::uint64_t> changed_chunks;  ///< ascending keys
  std::uint64_t acked = 0;   ///< the session's highest acknowledged sequence after this call
};

struct MapServerStats {
  std::uint64_t epoch = 0;
  std::string mode;
  std::size_t points = 0;
  std::size_t chunks = 0;
  double chunk_size = 0.0;
  std::uint64_t observations_applied = 0;   ///< in this map, in total (persisted)
  std::uint64_t observations_received = 0;  ///< since start, duplicates included
  std::uint64_t duplicates = 0;             ///< since start
  std::size_t journal_records = 0;          ///< since the last snapshot
  std::uint64_t snapshots = 0;              ///< written into the map directory since start
  std::string last_error;                   ///< of an automatic snapshot, empty when none failed
};

class MapServerCore {
 public:
  /// Loads the map directory (snapshot, then journal replay; problems are logged and kept in
  /// load_report()). Read-only (export tools): nothing on disk changes; apply, load and save into
  /// the directory are refused. Throws MapStorageError on I/O failure, ConfigError on bad config.
  explicit MapServerCore(const MapServerConfig& config,
                         MapStorage::Access access = MapStorage::Access::kReadWrite);

  /// One accepted observation (world-frame points of one scan). Throws MapStorageError when it
  /// cannot be journaled: it is then neither applied nor acknowledged.
  MapApplyResult apply(std::uint64_t session, std::uint64_t sequence, double t,
                       const std::vector<Eigen::Vector3f>& points);

  /// Highest acknowledged sequence of a session (0 when none).
  std::uint64_t acked(std::uint64_t session) const;
  const std::map<std::uint64_t, std::uint64_t>& acked_sequences() const { return acked_; }

  /// "mapping" or "localization" (std::invalid_argument otherwise).
  void set_mode(const std::string& mode);
  const std::string& mode() const { return meta_.mode; }

  /// Empty file: a snapshot into the map directory (the journal restarts empty). Otherwise a
  /// snapshot file written atomically at `file` (the directory is untouched). Returns the path.
  std::filesystem::path save(const std::filesystem::path& file = {});

  /// Replaces the map by a snapshot file's. On a missing or unreadable file (report.snapshot_ok
  /// false) nothing changes. Chunks the file has lost are reported and skipped.
  LoadReport load(const std::filesystem::path& file);

  MapServerStats stats() const;
  std::uint64_t epoch() const { return meta_.epoch; }
  const PointMap& map() const { return map_; }
  const SpatialIndex& index() const { return *index_; }
  const LoadReport& load_report() const { return load_report_; }
  const MapServerConfig& config() const { return config_; }

 private:
  void rebuild_index();
  std::vector<std::uint64_t> apply_points(const std::vector<Eigen::Vector3f>& points, std::size_t& inserted);

  MapServerConfig config_;
  MapStorage::Access access_;
  std::unique_ptr<MapStorage> storage_;
  PointMap map_;
  MapMeta meta_;
  std::unique_ptr<SpatialIndex> index_;
  std::unique_ptr<MapPolicy> mapping_;  ///< journal replay always maps, whatever the mode
  std::map<std::uint64_t, std::uint64_t> acked_;
  LoadReport load_report_;
  std::vector<Eigen::Vector3f> inserted_;
  std::uint64_t received_ = 0, duplicates_ = 0, snapshots_ = 0;
  std::string last_error_;
};

}  // namespace fuse

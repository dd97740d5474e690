// The map server's logic without transport (DESIGN §2, fuse-map): the persistent PointMap, an
// iVox index over the same points for the policy's nearest-neighbour tests, the mapping policy
// and the files (MapStorage). The service wraps it in DDS: observations in, changed chunks and
// status out, control requests (mode, save, load, stats).
//
// Observation rules, per session (one fuse-update instance), with sequences 1, 2, ...:
//   - acknowledged means durable: a session's acknowledged sequence S is the highest such that
//     every sequence of the session up to S is journaled (fsync'd) or in the snapshot, or was
//     given up by its sender (session_acks.hpp). An observation journaled above a hole is
//     remembered and acknowledged once the hole is filled; each observation tells the lowest
//     sequence its sender still holds, which acknowledges what the sender gave up;
//   - an observation already acknowledged, journaled or pending is a duplicate (a re-send): it
//     is acknowledged again (as far as the rule allows) and nothing else happens;
//   - mapping: the observation is journaled first, then applied through the policy;
//   - localization: the map is frozen; the observation is acknowledged but neither journaled nor
//     applied (it would not change the map): settled like one its sender gave up. That lives in
//     memory until the next snapshot; after a restart without one, the sender's lowest_unacked
//     settles those sequences again.
// Degraded (the journal or a snapshot cannot be written: full disk, read-only file system, an
// unwritable directory at start-up): observations that cannot be journaled are kept in memory in
// arrival order (pending, bounded by max_pending_bytes: beyond it the oldest is dropped and
// counted; it stays unacknowledged, so its sender still holds it), and nothing new is
// acknowledged. A pending observation is applied to the map when it arrives, so that it is
// served (a replica rebuilt meanwhile has it); as pending observations are journaled in arrival
// order with nothing applied between them, the map is the one journal-then-apply gives.
// retry() (every retry_interval_s) makes the directory writable again if it can, journals the
// pending in order and acknowledges them, then writes a due snapshot (one that keeps failing
// is tried at growing intervals, at most every kMaxSnapshotBackoff retries: it rewrites the whole
// map each time); the core is running again once nothing is pending and the journal and
// snapshots work. With a spill directory on another file system, the pending observations are
// journaled there as well and survive a restart of the server (taken back at start-up, emptied
// once all are journaled in the map directory). Repeated failures are logged
// rate-limited, with counts (fuse::Counters).
// Restart: snapshot + journal replay rebuild the same map, point for point, and the same
// acknowledged sequences. A damaged load keeps every good record and, with write access, is
// settled by a snapshot at once. The start-up mode is the configured one (`policy.mode`); the
// mode in a snapshot records the mode when it was written.
// Replacing the map (load) keeps every session's acknowledgements (they never go back),
// increases the epoch, and is made durable at once by a snapshot into the map directory.
//
// Not thread-safe: the service serialises calls.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "fuse/association/spatial_index.hpp"
#include "fuse/core/config.hpp"
#include "fuse/core/counters.hpp"
#include "fuse/map/map_policy.hpp"
#include "fuse/map/map_storage.hpp"
#include "fuse/map/point_map.hpp"

namespace fuse {

struct MapServerConfig {
  /// iVox capacity of the server's index: the persistent map must never be evicted.
  static constexpr std::size_t kNoEviction = 2147483647;  // iVox voxel indices are 32-bit
  /// Default bound of the observations kept in memory while the journal cannot be written:
  /// about 100 s of 20 000-point scans at 10 Hz.
  static constexpr std::size_t kDefaultMaxPendingBytes = std::size_t{256} << 20;
  /// Smallest bound accepted: several of the largest observations (262 144 points, 3 MiB).
  static constexpr std::size_t kMinPendingBytes = std::size_t{16} << 20;

  std::string directory = "map";     ///< map.snapshot and map.journal live here (created if missing)
  double chunk_size = 20.0;          ///< m, of a new map (a snapshot keeps its own)
  std::size_t snapshot_every = 500;  ///< journaled observations between automatic snapshots; 0: only on save
  bool fsync = true;                 ///< false only for benches: acknowledged data may then be lost
  /// Observations that could not be journaled are kept in memory up to this many bytes of points
  /// (the oldest dropped beyond it: unacknowledged, so its sender still holds it).
  std::size_t max_pending_bytes = kDefaultMaxPendingBytes;
  double retry_interval_s = 2.0;     ///< while degraded: s between attempts to write again
  /// Where the observations kept in memory are also written (a journal of their own), on another
  /// file system than `directory` (the service's runtime directory, a tmpfs): a fuse-map killed
  /// while the map disk is full then finds them again at start-up, although the fuse-update that
  /// sent them may be gone too. Emptied once every pending observation is journaled. Empty: kept
  /// in memory only.
  std::string spill_directory;
  /// Where the control RPC's `save NAME` writes and `load NAME` reads (map_names.hpp): never the
  /// map directory itself, whose live snapshot and journal no name may reach. Empty: DIR/saved.
  std::string saved_directory;
  /// Not a map_server key: fuse-map sets it from transport.system_name. Snapshots record it, and
  /// a saved map recorded under another name is loaded only when asked for explicitly.
  std::string system_name;
  /// saved_directory, or its default.
  std::filesystem::path saved_maps() const;
  MapPolicyConfig policy;            ///< policy.mode is the mode at start-up
  /// The policy's nearest-neighbour index over the map's points. A restart rebuilds the same map
  /// when the index holds every point: it never evicts (max_voxels), and max_points_per_voxel
  /// should stay above what min_point_distance lets into one voxel (64 > (0.5/0.25 + 1)^3 by default).
  SpatialIndexConfig index = default_index();

  static SpatialIndexConfig default_index();
  void load(ConfigNode& node);
};

struct MapApplyResult {
  bool duplicate = false;  ///< already acknowledged, journaled or pending: nothing done
  bool applied = false;    ///< journaled and offered to the policy (mapping mode)
  bool pending = false;    ///< not journaled (degraded): applied and served, kept, not acknowledged
  std::size_t inserted = 0;
  std::size_t rejected = 0;  ///< points not finite or outside the chunk key range, dropped
  std::vector<std::uint64_t> changed_chunks;  ///< ascending keys
  std::uint64_t acked = 0;   ///< the session's acknowledged sequence after this call
};

struct MapRetryResult {
  std::size_t journaled = 0;  ///< pending observations journaled and acknowledged by this call
  bool more = false;          ///< pending observations are left and writing works: call again now
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
  bool degraded = false;                    ///< see MapServerCore::degraded()
  std::string degraded_reason;              ///< why, empty when running
  std::size_t pending = 0;                  ///< observations kept in memory, not journaled
  std::size_t pending_bytes = 0;
  /// Since start, by reason: journal_errors, snapshot_errors, observations_deferred (kept in
  /// memory), pending_dropped (beyond max_pending_bytes), write_retries_failed.
  std::map<std::string, std::uint64_t> counters;
};

class MapServerCore {
 public:
  /// Loads the map directory (snapshot, then journal replay; problems are logged and kept in
  /// load_report()). Read-only (export tools): nothing on disk changes; apply, load and save into
  /// the directory are refused. Read-write on a directory that cannot be written: loads what is
  /// there and starts degraded (retry() tries again). Throws MapDirectoryLocked when another
  /// process holds the directory, MapStorageError when a file cannot be read, ConfigError on a
  /// bad config.
  explicit MapServerCore(const MapServerConfig& config,
                         MapStorage::Access access = MapStorage::Access::kReadWrite);

  /// One accepted observation (world-frame points of one scan). lowest_unacked: the sender holds
  /// nothing of the session unacknowledged below it (0: not said; at most sequence). Never
  /// throws on a write failure: the observation is then kept pending (result.pending).
  /// std::invalid_argument for session or sequence 0 or lowest_unacked above sequence.
  MapApplyResult apply(std::uint64_t session, std::uint64_t sequence, double t,
                       const std::vector<Eigen::Vector3f>& points, std::uint64_t lowest_unacked = 0);

  /// While degraded: see the file comment. Call every config().retry_interval_s, and at once
  /// again while the result says more.
  MapRetryResult retry();
  /// The journal or a snapshot cannot be written, or observations are pending.
  bool degraded() const;
  /// Why degraded (empty when not).
  std::string degraded_reason() const;

  /// Acknowledged sequence of a session (0 when none). An observation that continues it is
  /// acknowledged when journaled; one above a hole once the hole is filled or given up.
  std::uint64_t acked(std::uint64_t session) const;
  /// Every session's acknowledged sequence.
  std::map<std::uint64_t, std::uint64_t> acked_sequences() const;
  /// (session, acknowledged sequence) of at most n sessions, most recently active first (after a
  /// restart: in the order the snapshot and journal had them).
  std::vector<std::pair<std::uint64_t, std::uint64_t>> recent_sessions(std::size_t n) const;
  /// The most recently active session (0 when none).
  std::uint64_t newest_session() const;
  /// What is durable per session (acknowledged, and above holes).
  const SessionAcks& session_acks() const { return meta_.acks; }

  /// The map frame's gravity direction, as its snapshot recorded it or the first session that
  /// mapped it said (MapObservation.gravity); written with every snapshot.
  const std::optional<Eigen::Vector3d>& gravity() const { return meta_.gravity; }
  /// A mapping session's gravity direction in the map frame: kept when the map has none yet
  /// (a direction within max_tilt rad of −z; anything else is refused and false returned).
  bool note_gravity(const Eigen::Vector3d& g, double max_tilt);
  /// "mapping" or "localization" (std::invalid_argument otherwise).
  void set_mode(const std::string& mode);
  const std::string& mode() const { return meta_.mode; }

  /// Empty file: a snapshot into the map directory (the journal restarts empty; refused with
  /// MapStorageError while observations are pending). Otherwise a snapshot file written
  /// atomically at `file` (the directory is untouched). Returns the path.
  std::filesystem::path save(const std::filesystem::path& file = {});

  /// Replaces the map by a snapshot file's. On a missing or unreadable file (report.snapshot_ok
  /// false) nothing changes. Chunks the file has lost are reported and skipped. Refused with
  /// MapStorageError while degraded.
  LoadReport load(const std::filesystem::path& file);

  MapServerStats stats() const;
  std::uint64_t epoch() const { return meta_.epoch; }
  const PointMap& map() const { return map_; }
  const SpatialIndex& index() const { return *index_; }
  /// The map directory's load at start-up.
  const LoadReport& load_report() const { return load_report_; }
  const MapServerConfig& config() const { return config_; }

 private:
  /// Most observations one retry() journals with one fsync, and most bytes of their points.
  static constexpr std::size_t kRetryBatchRecords = 64;
  static constexpr std::size_t kRetryBatchBytes = std::size_t{16} << 20;
  /// Most retry() calls between two attempts of a snapshot that keeps failing.
  static constexpr std::size_t kMaxSnapshotBackoff = 32;

  struct Pending {
    MapObservation observation;
    std::size_t bytes = 0;
  };

  void rebuild_index();
  std::vector<std::uint64_t> apply_points(double t, const std::vector<Eigen::Vector3f>& points, std::size_t& inserted);
  /// Applies a journaled observation to the map and acknowledges it as far as the rule allows.
  std::vector<std::uint64_t> apply_durable(const MapObservation& observation, std::size_t& inserted);
  bool duplicate(std::uint64_t session, std::uint64_t sequence) const;
  /// Applies its points to the map (the changed chunks returned, `inserted` set) and keeps it
  /// until it is journaled; spill: also write it to the spill journal (not when it came from there).
  std::vector<std::uint64_t> keep_pending(MapObservation observation, std::size_t& inserted, bool spill = true);
  /// Opens the spill directory and takes back what a previous instance left pending there.
  void open_spill();
  /// Empties the spill journal once nothing is pending.
  void clear_spill();
  void journal_failed(const MapObservation& observation);
  bool snapshot_due() const;
  /// Writes a snapshot into the directory; false (counted, kept for degraded_reason) on failure.
  bool try_snapshot(const char* why);

  MapServerConfig config_;
  MapStorage::Access access_;
  std::unique_ptr<MapStorage> storage_;
  std::unique_ptr<MapStorage> spill_;  ///< the pending observations' own journal (spill_directory)
  bool spill_dirty_ = false;           ///< the spill journal holds records
  PointMap map_;
  MapMeta meta_;
  std::unique_ptr<SpatialIndex> index_;
  std::unique_ptr<MapPolicy> mapping_;  ///< journal replay always maps, whatever the mode
  std::deque<Pending> pending_;
  std::set<std::pair<std::uint64_t, std::uint64_t>> pending_ids_;  ///< (session, sequence) of pending_
  std::size_t pending_bytes_ = 0;
  bool snapshot_wanted_ = false;  ///< the load was damaged (or a save failed): a snapshot settles it
  std::string snapshot_error_;    ///< the last snapshot's failure, empty once one succeeded
  std::size_t snapshot_backoff_ = 0;     ///< retries between attempts after the last failure
  std::size_t retries_to_snapshot_ = 0;  ///< retries left before the next attempt
  LoadReport load_report_;
  std::vector<Eigen::Vector3f> inserted_;
  std::uint64_t received_ = 0, duplicates_ = 0, snapshots_ = 0;
  Counters counters_;
};

}  // namespace fuse

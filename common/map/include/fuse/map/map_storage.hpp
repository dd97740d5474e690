// Persistent map files (DESIGN §4): a snapshot written atomically and an append-only journal of
// the observations accepted since, both in one directory:
//
//   map.snapshot   "FUSEMAPS" u32 version | header record | one record per chunk
//   map.journal    "FUSEMAPJ" u32 version | one record per accepted observation
//
// Every record is framed as [u32 length][u32 crc32 of the bytes][protobuf bytes] (little-endian,
// CRC-32/IEEE, messages in proto/map.proto). The snapshot header holds the format version, frame
// id "world", chunk size, min_point_distance, mode, epoch and, per session, the highest applied
// observation sequence; a chunk record holds key, ix, iy, iz, revision and packed float xyz.
//
// Durability: append() returns once the record is written and fsync'd. A snapshot goes to a temp
// file in the same directory, is fsync'd, renamed over the old one and the directory fsync'd;
// then the journal restarts empty (again by an atomic rename). A crash between the two leaves
// journal records the snapshot already holds: load() skips every record whose sequence is at or
// below the snapshot's for its session, so nothing is applied twice.
//
// Damage: load() never throws on bad contents. Every bad part is found by its length or CRC,
// reported in the LoadReport (file, byte offset, what) and the good part kept: a chunk record
// with a bad CRC is dropped alone; an unreadable snapshot header means starting from the journal
// only (the file is moved aside to map.snapshot.bad.N); the journal is cut at its first bad or
// truncated record (the cut bytes are kept in map.journal.cut.N) so that appends follow good data.
// Only I/O failures (unwritable directory, full disk) throw MapStorageError.
//
// One process at a time: a read-write MapStorage holds an exclusive lock on map.lock (released
// by the kernel when the process dies, so a SIGKILLed server can restart at once).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "fuse/map/point_map.hpp"

namespace fuse {

/// An I/O failure on the map files (the contents being bad is reported, never thrown).
class MapStorageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// World-frame points of one accepted scan; (session, sequence) identifies it.
struct MapObservation {
  std::uint64_t session = 0;
  std::uint64_t sequence = 0;
  double t = 0.0;
  std::vector<Eigen::Vector3f> points;
};

/// The snapshot header's contents besides the chunks (the chunk size is the PointMap's).
struct MapMeta {
  std::string frame_id = "world";
  double min_point_distance = 0.0;
  std::string mode = "mapping";
  std::uint64_t epoch = 0;         ///< increases each time the map is replaced (load)
  std::uint64_t observations = 0;  ///< observations applied to this map, in total
  std::map<std::uint64_t, std::uint64_t> applied;  ///< session -> highest applied sequence
};

/// What a load found; `problems` names the file and byte offset of every bad part.
struct LoadReport {
  bool snapshot_found = false;
  bool snapshot_ok = false;  ///< its header was readable: its good chunks are loaded
  std::size_t chunks_loaded = 0;
  std::size_t chunks_dropped = 0;
  bool journal_found = false;
  std::size_t journal_records = 0;    ///< good records (kept in the journal)
  std::size_t journal_replayed = 0;   ///< of those, applied on top of the snapshot
  std::size_t journal_skipped = 0;    ///< of those, already in the snapshot
  std::uint64_t journal_bytes_cut = 0;  ///< bad tail removed (read-only: ignored)
  std::vector<std::string> problems;

  bool clean() const { return problems.empty(); }
  /// One line: counts, and the number of problems.
  std::string summary() const;
};

class MapStorage {
 public:
  static constexpr std::uint32_t kFormatVersion = 1;
  static constexpr const char* kSnapshotName = "map.snapshot";
  static constexpr const char* kJournalName = "map.journal";

  enum class Access {
    kReadWrite,  ///< creates the directory, locks it, repairs the journal, appends
    kReadOnly    ///< reads only (export tools): nothing is created, cut or moved
  };

  /// fsync false skips every fsync (benches only: an acknowledged record may then be lost).
  /// Read-write: creates the directory if needed and locks it; MapStorageError if it cannot.
  explicit MapStorage(std::filesystem::path directory, bool fsync = true, Access access = Access::kReadWrite);
  ~MapStorage();
  MapStorage(const MapStorage&) = delete;
  MapStorage& operator=(const MapStorage&) = delete;

  using ReplayFn = std::function<void(const MapObservation&)>;
  /// Loads the snapshot into map and meta (both replaced; the map takes the snapshot's chunk
  /// size; no snapshot: map cleared, meta reset), then hands every journal record not covered by
  /// meta.applied to replay, updating meta.applied and meta.observations. Read-write: then opens
  /// the journal for append (creating it if missing). Call once, before append().
  LoadReport load(PointMap& map, MapMeta& meta, const ReplayFn& replay);

  /// Appends one journal record; returns once it is written (and fsync'd). On failure the journal
  /// is rolled back to its previous end and MapStorageError thrown.
  void append(const MapObservation& observation);

  /// Writes map.snapshot atomically, then restarts the journal empty.
  void snapshot(const PointMap& map, const MapMeta& meta);

  std::size_t journal_records() const { return journal_records_; }
  std::uint64_t journal_bytes() const { return journal_size_; }
  const std::filesystem::path& directory() const { return directory_; }
  std::filesystem::path snapshot_path() const { return directory_ / kSnapshotName; }
  std::filesystem::path journal_path() const { return directory_ / kJournalName; }

  /// Writes a snapshot file atomically (temp file beside it, fsync, rename, fsync directory).
  static void write_snapshot_file(const std::filesystem::path& file, const PointMap& map, const MapMeta& meta,
                                  bool fsync = true);
  /// Reads a snapshot file into map and meta (replaced when its header is readable, untouched
  /// otherwise). A missing or unreadable file is reported (snapshot_ok false), never thrown.
  static LoadReport read_snapshot_file(const std::filesystem::path& file, PointMap& map, MapMeta& meta);
  /// Reads only a snapshot file's header into meta; false (meta untouched) when it is unreadable.
  static bool read_snapshot_header(const std::filesystem::path& file, MapMeta& meta);

 private:
  void load_journal(MapMeta& meta, const ReplayFn& replay, LoadReport& report);
  void reset_journal();
  void open_journal_for_append();
  void close_journal();

  std::filesystem::path directory_;
  bool fsync_;
  Access access_;
  int lock_fd_ = -1;
  int journal_fd_ = -1;
  bool loaded_ = false;
  std::uint64_t journal_size_ = 0;
  std::size_t journal_records_ = 0;
};

}  // namespace fuse

// Persistent map files (DESIGN §4): a snapshot written atomically and an append-only journal of
// the observations accepted since, both in one directory:
//
//   map.snapshot   "FUSEMAPS" u32 version | header record | one record per chunk
//   map.journal    "FUSEMAPJ" u32 version | one record per accepted observation
//
// Every record is framed as [u32 length][u32 crc32 of the bytes][protobuf bytes] (little-endian,
// CRC-32/IEEE, messages in proto/map.proto). The snapshot header holds the format version, frame
// id "world", chunk size, min_point_distance, mode, epoch and, per session, the acknowledged
// sequence and what is durable above it (session_acks.hpp); a chunk record holds key, ix, iy,
// iz, revision and packed float xyz. A journal record also holds the lowest sequence its sender
// still held unacknowledged, so that a replay reconstructs the acknowledgements exactly.
//
// Durability: append() returns once the records are written and fsync'd. A failed append (full
// disk, read-only file system, I/O error) leaves the journal as it was before it: a torn record
// is truncated away, and after a failed fsync the whole batch is (what the kernel wrote may be
// lost); writable() then stays false until make_writable() succeeds. The journal is opened for
// each append, not held open: holding no file open for writing lets an administrator remount the
// file system read-only while the server runs. A snapshot goes to a temp file in the same
// directory, is fsync'd, renamed over the old one and the directory fsync'd; then the journal
// restarts empty (again by an atomic rename). A crash between the two leaves journal records the
// snapshot already holds: load() skips every record the snapshot's session state covers
// (acknowledged or durable above a hole), so nothing is applied twice.
//
// Damage: load() never throws on bad contents. Every bad part is found by its length, CRC or
// contents, reported in the LoadReport (file, byte offset, bytes skipped) and the good part kept:
// after a bad record the reader resynchronises on the framing (the next offset where a length
// that fits, a matching CRC and a valid record start) and keeps every later good record. An
// unreadable snapshot header means starting from the journal only (the file is moved aside to
// map.snapshot.bad.N). A bad journal tail is cut (the bytes kept in map.journal.cut.N) so that
// appends follow good data; a journal or snapshot damaged within is settled by the next
// snapshot (MapServerCore writes one at once), which keeps the damaged file as *.bad.N.
// Unreadable files throw MapStorageError; an unwritable directory does not (writable()).
//
// One process at a time: a read-write MapStorage holds an exclusive lock on map.lock (released
// by the kernel when the process dies, so a SIGKILLed server can restart at once).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <optional>
#include <string>
#include <vector>

#include "fuse/map/point_map.hpp"
#include "fuse/map/session_acks.hpp"

namespace fuse {

/// An I/O failure on the map files (the contents being bad is reported, never thrown).
class MapStorageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The map directory is locked by another running process (a second map server on it).
class MapDirectoryLocked : public MapStorageError {
 public:
  using MapStorageError::MapStorageError;
};

/// World-frame points of one accepted scan; (session, sequence) identifies it.
struct MapObservation {
  std::uint64_t session = 0;
  std::uint64_t sequence = 0;
  double t = 0.0;
  std::vector<Eigen::Vector3f> points;
  /// The sender held nothing of the session unacknowledged below this (0: not said).
  std::uint64_t lowest_unacked = 0;
};

/// The snapshot header's contents besides the chunks (the chunk size is the PointMap's).
struct MapMeta {
  std::string frame_id = "world";
  double min_point_distance = 0.0;
  std::string mode = "mapping";
  std::uint64_t epoch = 0;         ///< increases each time the map is replaced (load)
  std::uint64_t observations = 0;  ///< observations applied to this map, in total
  SessionAcks acks;                ///< per session: acknowledged, and durable above a hole
  std::string system_name;         ///< transport.system_name of the system that built it (empty: default)
  /// Unit gravity direction in the map frame (about −z: the frame is gravity-aligned at its start,
  /// and an estimated gravity may have moved since); empty when the writer did not know it.
  std::optional<Eigen::Vector3d> gravity;
};

/// Bytes of a file that a load skipped as damaged.
struct DamagedRange {
  std::string file;  ///< the file read
  std::uint64_t offset = 0;
  std::uint64_t bytes = 0;
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
  std::uint64_t journal_bytes_cut = 0;  ///< bad tail: cut (kept in map.journal.cut.N), read-only: ignored
  /// Observations lost in damaged journal ranges, from the sequence gap across each range (a
  /// range at the end of the journal hides how many it held: their senders re-send them).
  std::size_t journal_records_lost = 0;
  std::vector<DamagedRange> damaged;  ///< every range skipped, in file order
  std::vector<std::string> problems;

  bool clean() const { return problems.empty(); }
  std::uint64_t bytes_skipped() const;
  /// One line: counts, and the number of problems.
  std::string summary() const;
};

class MapStorage {
 public:
  static constexpr std::uint32_t kFormatVersion = 1;
  static constexpr const char* kSnapshotName = "map.snapshot";
  static constexpr const char* kJournalName = "map.journal";
  static constexpr const char* kLockName = "map.lock";

  enum class Access {
    kReadWrite,  ///< creates the directory, locks it, repairs the journal, appends
    kReadOnly    ///< reads only (export tools): nothing is created, cut or moved
  };

  /// fsync false skips every fsync (benches only: an acknowledged record may then be lost).
  /// Read-write: creates the directory and takes its lock when it can. A directory that cannot
  /// be written (read-only file system, no permission) is no error: load() reads what is there
  /// and writable() says false until make_writable() succeeds. Throws MapDirectoryLocked when
  /// another process holds the lock.
  explicit MapStorage(std::filesystem::path directory, bool fsync = true, Access access = Access::kReadWrite);
  ~MapStorage();
  MapStorage(const MapStorage&) = delete;
  MapStorage& operator=(const MapStorage&) = delete;

  using ReplayFn = std::function<void(const MapObservation&)>;
  /// Loads the snapshot into map and meta (both replaced; the map takes the snapshot's chunk
  /// size; no snapshot: map cleared, meta reset), then hands every journal record not covered by
  /// meta.acks to replay, adding it to meta.acks and meta.observations. Read-write: then repairs
  /// what it found and checks the journal for appending (make_writable()). Call once.
  /// Throws MapStorageError only when a file exists but cannot be read.
  LoadReport load(PointMap& map, MapMeta& meta, const ReplayFn& replay);

  /// Whether appends can be tried: the directory is locked, repaired after the load and its
  /// journal opened for writing when last tried. False after a failed write.
  bool writable() const { return writable_; }
  /// Why not writable() (empty when it is).
  const std::string& write_error() const { return write_error_; }
  /// Retries what writing needs (directory, lock, the repairs the load found, the journal);
  /// true once writable. Never throws.
  bool make_writable();

  /// Appends the observations in order and fsyncs once; returns how many are durable (a prefix
  /// of the batch; all of them unless a write failed). On a failure the journal is left as it
  /// was after the durable ones, writable() turns false and write_error() says why. Not
  /// writable(): writes nothing, returns 0.
  std::size_t append(const std::vector<const MapObservation*>& batch);
  /// One observation; throws MapStorageError when it is not durable (tries make_writable() first).
  void append(const MapObservation& observation);

  /// Writes map.snapshot atomically, then restarts the journal empty. A snapshot or journal that
  /// the load found damaged is first kept beside as *.bad.N. Throws MapStorageError; the files
  /// then hold what they held (or the new snapshot and a journal whose records it covers).
  void snapshot(const PointMap& map, const MapMeta& meta);
  /// The load found damage a snapshot should settle: good journal records after a damaged
  /// range, or chunk records lost from the snapshot.
  bool damaged() const { return journal_damaged_ || snapshot_damaged_; }

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
  /// What the load found that writing must settle first (done by make_writable()).
  struct Repairs {
    bool remove_temp = false;        ///< leftovers of a write interrupted before its rename
    bool snapshot_aside = false;     ///< unreadable snapshot: moved to map.snapshot.bad.N
    bool journal_aside = false;      ///< not a journal: moved to map.journal.bad.N
    bool journal_create = false;     ///< missing (or moved aside): created empty
    std::uint64_t journal_cut = 0;   ///< > 0: a bad tail from here to the end is cut
    std::uint64_t journal_size = 0;  ///< the journal's size when loaded (a cut needs the same file)
  };

  void lock();
  void load_journal(MapMeta& meta, const ReplayFn& replay, LoadReport& report);
  /// make_writable(), adding what the repairs did to report's problems when given.
  bool prepare_writing(LoadReport* report);
  /// Opens the journal for appending at journal_size_ (rolling back the rest of a failed write);
  /// throws MapStorageError.
  int open_journal();
  void reset_journal();
  void fail_writing(const std::string& why);

  std::filesystem::path directory_;
  bool fsync_;
  Access access_;
  int lock_fd_ = -1;
  bool loaded_ = false;
  bool writable_ = false;
  std::string write_error_;
  Repairs repairs_;
  bool journal_damaged_ = false;
  bool snapshot_damaged_ = false;
  std::uint64_t journal_size_ = 0;
  std::size_t journal_records_ = 0;
};

}  // namespace fuse

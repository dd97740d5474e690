#include "fuse/map/map_storage.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "map.pb.h"
#include "record_file.hpp"

namespace fuse {

namespace fs = std::filesystem;
using record_file::FrameReader;
using record_file::FrameStatus;

namespace {

constexpr char kSnapshotMagic[] = "FUSEMAPS";
constexpr char kJournalMagic[] = "FUSEMAPJ";
/// Snapshot bytes buffered before each write.
constexpr std::size_t kWriteBuffer = 4u << 20;
/// Every record these files hold starts with its field 1 as a varint (format version, session or
/// chunk key, never 0), which protobuf writes first: the tag byte (1 << 3 | wire type 0). A
/// resync only considers payloads that start with it.
constexpr char kFirstFieldTag = 0x08;

std::string at(const fs::path& file, std::uint64_t offset) {
  return file.string() + ": byte " + std::to_string(offset) + ": ";
}

/// What went wrong with a record that next() did not return as kOk (or that did not parse).
std::string describe(const FrameReader& reader, FrameStatus status) {
  if (status == FrameStatus::kOk) return "does not parse as a record";
  if (status == FrameStatus::kBadCrc) {
    return "fails its CRC (" + std::to_string(reader.frame_length()) + " bytes)";
  }
  const std::uint64_t left = reader.file_size() - reader.frame_offset();
  if (left < record_file::kFrameHeaderSize) return "is truncated (" + std::to_string(left) + " bytes of its frame header)";
  return "announces " + std::to_string(reader.frame_length()) + " bytes, only " +
         std::to_string(left - record_file::kFrameHeaderSize) + " left (truncated, or a corrupted length)";
}

void to_floats(const std::vector<Eigen::Vector3f>& points, google::protobuf::RepeatedField<float>& xyz) {
  xyz.Resize(static_cast<int>(3 * points.size()), 0.f);
  if (!points.empty()) std::memcpy(xyz.mutable_data(), points.data(), points.size() * sizeof(Eigen::Vector3f));
}

std::vector<Eigen::Vector3f> from_floats(const google::protobuf::RepeatedField<float>& xyz) {
  std::vector<Eigen::Vector3f> points(static_cast<std::size_t>(xyz.size()) / 3);
  const float* v = xyz.data();
  for (Eigen::Vector3f& p : points) {
    p = Eigen::Vector3f(v[0], v[1], v[2]);
    v += 3;
  }
  return points;
}

static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "points are copied as packed float triples");

/// A journal record as written: parses, identifies its observation, holds whole points.
bool valid_observation(const std::string& payload, map::pb::Observation& record) {
  return record.ParseFromString(payload) && record.session() != 0 && record.sequence() != 0 &&
         record.xyz_size() % 3 == 0;
}

/// A chunk record as written: parses, its key matches its coordinates, holds whole points.
bool valid_chunk(const std::string& payload, map::pb::Chunk& record) {
  if (!record.ParseFromString(payload) || record.xyz_size() % 3 != 0) return false;
  const Eigen::Vector3i coord(record.ix(), record.iy(), record.iz());
  for (int i = 0; i < 3; ++i) {
    if (coord[i] < PointMap::kCoordMin || coord[i] > PointMap::kCoordMax) return false;
  }
  return PointMap::pack_key(coord) == record.key();
}

/// Copies bytes [from, end) of file to a new file `dest` (the journal's cut tail, kept for forensics).
void copy_tail(const fs::path& file, std::uint64_t from, const fs::path& dest, bool fsync) {
  std::ifstream in(file, std::ios::binary);
  in.seekg(static_cast<std::streamoff>(from));
  if (!in) throw MapStorageError("cannot read " + file.string());
  record_file::FileWriter out(dest, O_WRONLY | O_CREAT | O_EXCL);
  std::string block(1u << 20, '\0');
  while (in.read(block.data(), static_cast<std::streamsize>(block.size())) || in.gcount() > 0) {
    out.write(block.substr(0, static_cast<std::size_t>(in.gcount())));
  }
  if (fsync) out.sync();
  out.close();
}

/// Keeps file under the first free name base.N (base = file + suffix): a hard link, so that the
/// atomic replacement that follows leaves the old contents there; a copy where links fail.
/// Returns the name used, empty when file does not exist.
std::string keep_beside(const fs::path& file, const std::string& suffix, bool fsync) {
  std::error_code ec;
  if (!fs::exists(file, ec)) return {};
  const fs::path side = record_file::free_side_name(fs::path(file.string() + suffix));
  if (::link(file.c_str(), side.c_str()) != 0) copy_tail(file, 0, side, fsync);
  return side.filename().string();
}

void truncate_file(const fs::path& file, std::uint64_t size, bool fsync) {
  const int fd = ::open(file.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0 || ::ftruncate(fd, static_cast<off_t>(size)) != 0 || (fsync && ::fsync(fd) != 0)) {
    const int err = errno;
    if (fd >= 0) ::close(fd);
    throw MapStorageError("cannot truncate " + file.string() + ": " + std::strerror(err));
  }
  ::close(fd);
}

MapMeta meta_of(const map::pb::SnapshotHeader& header) {
  MapMeta meta;
  meta.frame_id = header.frame_id();
  meta.min_point_distance = header.min_point_distance();
  meta.mode = header.mode();
  meta.epoch = header.epoch();
  meta.observations = header.observations();
  meta.system_name = header.system_name();
  if (header.has_gravity()) {
    const Eigen::Vector3d g(header.gravity().x(), header.gravity().y(), header.gravity().z());
    if (g.allFinite() && std::abs(g.norm() - 1.0) < 1e-3) meta.gravity = g;  // anything else is not a direction
  }
  // Stored most recently active first: restored oldest first, so that the order is kept.
  for (auto it = header.applied().rbegin(); it != header.applied().rend(); ++it) {
    std::vector<std::pair<std::uint64_t, std::uint64_t>> ranges;
    for (const auto& r : it->durable_above()) {
      if (r.first() != 0 && r.first() <= r.last()) ranges.emplace_back(r.first(), r.last());
    }
    meta.acks.restore(it->session(), it->sequence(), ranges);
  }
  return meta;
}

}  // namespace

std::uint64_t LoadReport::bytes_skipped() const {
  std::uint64_t n = 0;
  for (const DamagedRange& r : damaged) n += r.bytes;
  return n;
}

std::string LoadReport::summary() const {
  std::ostringstream s;
  s << "snapshot: ";
  if (!snapshot_found) {
    s << "none";
  } else {
    s << (snapshot_ok ? "" : "unreadable, ") << chunks_loaded << " chunks loaded, " << chunks_dropped << " dropped";
  }
  s << "; journal: ";
  if (!journal_found) {
    s << "none";
  } else {
    s << journal_records << " records (" << journal_replayed << " replayed, " << journal_skipped
      << " already in the snapshot), " << journal_records_lost << " lost, " << journal_bytes_cut << " bad bytes cut";
  }
  s << "; " << damaged.size() << " damaged range" << (damaged.size() == 1 ? "" : "s") << " (" << bytes_skipped()
    << " bytes skipped); " << problems.size() << " problem" << (problems.size() == 1 ? "" : "s");
  return s.str();
}

// ---- snapshot files -----------------------------------------------------------------------

void MapStorage::write_snapshot_file(const fs::path& file, const PointMap& map, const MapMeta& meta, bool fsync) {
  map::pb::SnapshotHeader header;
  header.set_format_version(kFormatVersion);
  header.set_frame_id(meta.frame_id);
  header.set_chunk_size(map.chunk_size());
  header.set_min_point_distance(meta.min_point_distance);
  header.set_mode(meta.mode);
  for (const std::uint64_t session : meta.acks.by_activity()) {
    const SessionAcks::Session& state = meta.acks.sessions().at(session);
    map::pb::SessionSequence* s = header.add_applied();
    s->set_session(session);
    s->set_sequence(state.acked);
    for (const auto& [first, last] : state.durable_above) {
      map::pb::SequenceRange* r = s->add_durable_above();
      r->set_first(first);
      r->set_last(last);
    }
  }
  header.set_epoch(meta.epoch);
  header.set_observations(meta.observations);
  header.set_system_name(meta.system_name);
  if (meta.gravity) {
    const Eigen::Vector3d g = meta.gravity->normalized();
    header.mutable_gravity()->set_x(g.x());
    header.mutable_gravity()->set_y(g.y());
    header.mutable_gravity()->set_z(g.z());
  }
  header.set_chunk_count(map.num_chunks());
  header.set_point_count(map.num_points());

  record_file::write_atomically(
      file,
      [&](record_file::FileWriter& writer) {
        std::string buffer = record_file::file_header(kSnapshotMagic, kFormatVersion);
        record_file::append_frame(buffer, header.SerializeAsString());
        map::pb::Chunk record;
        map.for_each_chunk([&](const PointChunk& chunk) {
          record.set_key(chunk.key);
          record.set_ix(chunk.coord.x());
          record.set_iy(chunk.coord.y());
          record.set_iz(chunk.coord.z());
          record.set_revision(chunk.revision);
          to_floats(chunk.points, *record.mutable_xyz());
          record_file::append_frame(buffer, record.SerializeAsString());
          if (buffer.size() >= kWriteBuffer) {
            writer.write(buffer);
            buffer.clear();
          }
        });
        writer.write(buffer);
      },
      fsync);
}

LoadReport MapStorage::read_snapshot_file(const fs::path& file, PointMap& map, MapMeta& meta) {
  LoadReport report;
  FrameReader reader(file);
  if (!reader.is_open()) {
    report.problems.push_back(file.string() + ": cannot open");
    return report;
  }
  report.snapshot_found = true;
  std::uint32_t version = 0;
  if (!reader.read_file_header(kSnapshotMagic, version)) {
    report.problems.push_back(at(file, 0) + "not a map snapshot (bad magic, or shorter than its file header)");
    return report;
  }
  if (version != kFormatVersion) {
    report.problems.push_back(at(file, 8) + "format version " + std::to_string(version) + ", this build reads " +
                              std::to_string(kFormatVersion));
    return report;
  }

  std::string payload;
  map::pb::SnapshotHeader header;
  const FrameStatus status = reader.next(payload);
  if (status != FrameStatus::kOk || !header.ParseFromString(payload)) {
    const std::string what = status == FrameStatus::kOk ? "header record does not parse"
                             : status == FrameStatus::kEnd ? "no header record"
                                                           : "header record " + describe(reader, status);
    report.problems.push_back(at(file, reader.frame_offset()) + what);
    return report;
  }
  if (!(std::isfinite(header.chunk_size()) && header.chunk_size() > 0.0) ||
      header.format_version() != kFormatVersion) {
    report.problems.push_back(at(file, reader.frame_offset()) + "header record has chunk_size " +
                              std::to_string(header.chunk_size()) + ", format version " +
                              std::to_string(header.format_version()));
    return report;
  }

  PointMap loaded(header.chunk_size());
  map::pb::Chunk record;
  const auto valid = [&](const std::string& bytes) { return valid_chunk(bytes, record); };
  for (;;) {
    const FrameStatus st = reader.next(payload);
    if (st == FrameStatus::kEnd) break;
    if (st == FrameStatus::kOk && valid(payload)) {
      PointChunk chunk;
      chunk.key = record.key();
      chunk.coord = Eigen::Vector3i(record.ix(), record.iy(), record.iz());
      chunk.revision = record.revision();
      chunk.points = from_floats(record.xyz());
      if (loaded.put_chunk(std::move(chunk))) {
        ++report.chunks_loaded;
        continue;
      }
      // Framed and parsed, but a point lies outside its chunk: this record alone is bad.
      report.problems.push_back(at(file, reader.frame_offset()) + "chunk record is not a valid chunk: dropped");
      report.damaged.push_back({file.string(), reader.frame_offset(), reader.offset() - reader.frame_offset()});
      continue;
    }
    // A damaged record: read on from the next record that the framing finds intact.
    const std::uint64_t start = reader.frame_offset();
    const std::string what = "chunk record " + describe(reader, st);
    const bool resumed = reader.resync(kFirstFieldTag, valid);
    const std::uint64_t end = resumed ? reader.offset() : reader.file_size();
    report.damaged.push_back({file.string(), start, end - start});
    report.problems.push_back(at(file, start) + what + ": " + std::to_string(end - start) + " bytes skipped" +
                              (resumed ? ", reading resumes at byte " + std::to_string(end) : " to the end"));
    if (!resumed) break;
  }
  // The header says how many chunks there were: every one not loaded is lost.
  const std::uint64_t expected = std::max<std::uint64_t>(header.chunk_count(), report.chunks_loaded);
  report.chunks_dropped = expected - report.chunks_loaded;
  if (report.chunks_dropped > 0 && report.damaged.empty()) {
    report.problems.push_back(at(file, reader.offset()) + "file ends after " + std::to_string(report.chunks_loaded) +
                              " of " + std::to_string(header.chunk_count()) + " chunk records (truncated)");
  }

  meta = meta_of(header);
  map = std::move(loaded);
  report.snapshot_ok = true;
  return report;
}

bool MapStorage::read_snapshot_header(const fs::path& file, MapMeta& meta) {
  FrameReader reader(file);
  std::uint32_t version = 0;
  std::string payload;
  map::pb::SnapshotHeader header;
  if (!reader.is_open() || !reader.read_file_header(kSnapshotMagic, version) || version != kFormatVersion ||
      reader.next(payload) != FrameStatus::kOk || !header.ParseFromString(payload)) {
    return false;
  }
  meta = meta_of(header);
  return true;
}

// ---- the map directory --------------------------------------------------------------------

MapStorage::MapStorage(fs::path directory, bool fsync, Access access)
    : directory_(std::move(directory)), fsync_(fsync), access_(access) {
  if (access_ == Access::kReadOnly) return;
  try {
    lock();
  } catch (const MapDirectoryLocked&) {
    throw;
  } catch (const MapStorageError& e) {
    write_error_ = e.what();  // unwritable for now: load() reads, make_writable() retries
  }
}

MapStorage::~MapStorage() {
  if (lock_fd_ >= 0) ::close(lock_fd_);
}

void MapStorage::lock() {
  if (lock_fd_ >= 0) return;
  std::error_code ec;
  fs::create_directories(directory_, ec);
  if (ec) throw MapStorageError("cannot create map directory " + directory_.string() + ": " + ec.message());
  // Opened read-only: flock needs no write access, and a file open for writing would keep the
  // file system from being remounted read-only.
  const fs::path file = directory_ / kLockName;
  const int fd = ::open(file.c_str(), O_RDONLY | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) throw MapStorageError("cannot open " + file.string() + ": " + std::strerror(errno));
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    ::close(fd);
    const std::string what = "map directory " + directory_.string() + " is in use by another process (" +
                             std::strerror(err) + ")";
    if (err == EWOULDBLOCK) throw MapDirectoryLocked(what);
    throw MapStorageError(what);
  }
  lock_fd_ = fd;
}

void MapStorage::fail_writing(const std::string& why) {
  writable_ = false;
  write_error_ = why;
}

bool MapStorage::make_writable() { return prepare_writing(nullptr); }

bool MapStorage::prepare_writing(LoadReport* report) {
  if (access_ != Access::kReadWrite || !loaded_) return false;
  auto note = [&](const std::string& problem) {
    if (report != nullptr) report->problems.push_back(problem);
  };
  try {
    lock();
    if (repairs_.remove_temp) {
      for (const char* name : {kSnapshotName, kJournalName}) {
        const fs::path tmp = directory_ / (std::string(name) + ".tmp");
        std::error_code ec;
        if (fs::exists(tmp, ec) && !fs::remove(tmp, ec)) {
          throw MapStorageError("cannot remove " + tmp.string() + ": " + ec.message());
        }
      }
      repairs_.remove_temp = false;
    }
    const fs::path snapshot = snapshot_path();
    const fs::path journal = journal_path();
    if (repairs_.snapshot_aside) {
      const fs::path aside = record_file::free_side_name(fs::path(snapshot.string() + ".bad"));
      if (::rename(snapshot.c_str(), aside.c_str()) != 0 && errno != ENOENT) {
        throw MapStorageError("cannot move " + snapshot.string() + " aside: " + std::strerror(errno));
      }
      repairs_.snapshot_aside = false;
      note(snapshot.string() + ": unreadable snapshot moved aside to " + aside.filename().string());
    }
    if (repairs_.journal_aside) {
      const fs::path aside = record_file::free_side_name(fs::path(journal.string() + ".bad"));
      if (::rename(journal.c_str(), aside.c_str()) != 0 && errno != ENOENT) {
        throw MapStorageError("cannot move " + journal.string() + " aside: " + std::strerror(errno));
      }
      repairs_.journal_aside = false;
      repairs_.journal_create = true;
      note(journal.string() + ": moved aside to " + aside.filename().string() + ", journal restarted");
    }
    if (repairs_.journal_cut > 0) {
      std::error_code ec;
      const std::uint64_t size = fs::file_size(journal, ec);
      if (ec || size != repairs_.journal_size) {
        throw MapStorageError(journal.string() + " changed since it was loaded: not cutting its damaged tail");
      }
      const fs::path side = record_file::free_side_name(fs::path(journal.string() + ".cut"));
      copy_tail(journal, repairs_.journal_cut, side, fsync_);
      truncate_file(journal, repairs_.journal_cut, fsync_);
      repairs_.journal_cut = 0;
      note(journal.string() + ": damaged tail cut at byte " + std::to_string(journal_size_) + ", kept in " +
           side.filename().string());
    }
    if (repairs_.journal_create) {
      reset_journal();
      repairs_.journal_create = false;
    }
    ::close(open_journal());
  } catch (const MapStorageError& e) {
    fail_writing(e.what());
    return false;
  }
  writable_ = true;
  write_error_.clear();
  return true;
}

int MapStorage::open_journal() {
  // A file longer than what was written holds the rest of a write that failed and could not be
  // rolled back then: roll it back before anything follows it.
  const fs::path journal = journal_path();
  const int fd = ::open(journal.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
  if (fd < 0) throw MapStorageError("cannot open " + journal.string() + " for writing: " + std::strerror(errno));
  struct stat st {};
  std::string error;
  if (::fstat(fd, &st) != 0) {
    error = "cannot stat " + journal.string() + ": " + std::strerror(errno);
  } else if (static_cast<std::uint64_t>(st.st_size) < journal_size_) {
    error = journal.string() + " is shorter than written (" + std::to_string(st.st_size) + " < " +
            std::to_string(journal_size_) + " bytes): changed by another process";
  } else if (static_cast<std::uint64_t>(st.st_size) > journal_size_ &&
             (::ftruncate(fd, static_cast<off_t>(journal_size_)) != 0 || (fsync_ && ::fsync(fd) != 0))) {
    error = "cannot roll " + journal.string() + " back to byte " + std::to_string(journal_size_) + ": " +
            std::strerror(errno);
  }
  if (error.empty()) return fd;
  ::close(fd);
  throw MapStorageError(error);
}

void MapStorage::reset_journal() {
  record_file::write_atomically(
      journal_path(), [](record_file::FileWriter& w) { w.write(record_file::file_header(kJournalMagic, kFormatVersion)); },
      fsync_);
  journal_size_ = record_file::kFileHeaderSize;
  journal_records_ = 0;
}

LoadReport MapStorage::load(PointMap& map, MapMeta& meta, const ReplayFn& replay) {
  if (loaded_) throw std::logic_error("MapStorage::load called twice");
  const bool writable = access_ == Access::kReadWrite;
  map = PointMap(map.chunk_size());
  meta = MapMeta{};
  LoadReport report;
  repairs_.remove_temp = writable;
  const fs::path snapshot = snapshot_path();
  std::error_code ec;
  if (fs::exists(snapshot, ec)) {
    report = read_snapshot_file(snapshot, map, meta);
    if (!report.snapshot_ok) {
      report.problems.push_back(snapshot.string() + ": snapshot unreadable: starting from the journal only");
      repairs_.snapshot_aside = writable;
    }
    snapshot_damaged_ = report.snapshot_ok && (report.chunks_dropped > 0 || !report.damaged.empty());
  }
  load_journal(meta, replay, report);
  loaded_ = true;
  if (writable) prepare_writing(&report);
  return report;
}

void MapStorage::load_journal(MapMeta& meta, const ReplayFn& replay, LoadReport& report) {
  const bool writable = access_ == Access::kReadWrite;
  const fs::path journal = journal_path();
  std::error_code ec;
  report.journal_found = fs::exists(journal, ec);
  if (!report.journal_found) {
    repairs_.journal_create = true;
    return;
  }
  FrameReader reader(journal);
  if (!reader.is_open()) throw MapStorageError("cannot read " + journal.string() + ": " + std::strerror(errno));
  repairs_.journal_size = reader.file_size();
  std::uint32_t version = 0;
  if (!reader.read_file_header(kJournalMagic, version) || version != kFormatVersion) {
    report.problems.push_back(at(journal, 0) + "not a map journal of format " + std::to_string(kFormatVersion) +
                              ": no record replayed");
    repairs_.journal_aside = writable;
    return;
  }

  std::uint64_t good_end = reader.offset();
  std::size_t records = 0;
  std::string payload;
  map::pb::Observation record;
  const auto valid = [&](const std::string& bytes) { return valid_observation(bytes, record); };
  MapObservation observation;
  // For the loss estimate: each session's last sequence before a damaged range, while no record
  // of that session has followed the range yet.
  std::map<std::uint64_t, std::uint64_t> last_sequence;
  std::set<std::uint64_t> after_damage;
  for (;;) {
    const FrameStatus st = reader.next(payload);
    if (st == FrameStatus::kEnd) break;
    if (st != FrameStatus::kOk || !valid(payload)) {
      const std::uint64_t start = reader.frame_offset();
      const std::string what = "record " + describe(reader, st);
      if (reader.resync(kFirstFieldTag, valid)) {
        const std::uint64_t end = reader.offset();
        report.damaged.push_back({journal.string(), start, end - start});
        report.problems.push_back(at(journal, start) + what + ": " + std::to_string(end - start) +
                                  " bytes skipped, reading resumes at byte " + std::to_string(end));
        journal_damaged_ = true;
        for (const auto& [session, sequence] : last_sequence) after_damage.insert(session);
        continue;
      }
      const std::uint64_t bytes = reader.file_size() - start;
      report.damaged.push_back({journal.string(), start, bytes});
      report.problems.push_back(at(journal, start) + what + ": the last " + std::to_string(bytes) + " bytes " +
                                (writable ? "are cut" : "are ignored (read-only)"));
      report.journal_bytes_cut = bytes;
      repairs_.journal_cut = writable ? start : 0;
      break;
    }
    ++records;
    good_end = reader.offset();
    std::uint64_t& last = last_sequence[record.session()];
    if (after_damage.erase(record.session()) > 0 && record.sequence() > last + 1) {
      report.journal_records_lost += record.sequence() - last - 1;
    }
    last = record.sequence();
    if (meta.acks.covered(record.session(), record.sequence())) {
      ++report.journal_skipped;
      continue;
    }
    meta.acks.add_durable(record.session(), record.sequence());
    meta.acks.raise_floor(record.session(), record.lowest_unacked());
    meta.acks.touch(record.session());
    ++meta.observations;
    ++report.journal_replayed;
    observation.session = record.session();
    observation.sequence = record.sequence();
    observation.lowest_unacked = record.lowest_unacked();
    observation.t = record.t();
    observation.points = from_floats(record.xyz());
    replay(observation);
  }
  report.journal_records = records;
  journal_records_ = records;
  journal_size_ = good_end;
}

std::size_t MapStorage::append(const std::vector<const MapObservation*>& batch) {
  if (access_ != Access::kReadWrite || !loaded_) {
    throw std::logic_error("MapStorage::append needs a read-write storage after load()");
  }
  if (!writable_ || batch.empty()) return 0;
  const fs::path journal = journal_path();
  int fd = -1;
  try {
    fd = open_journal();
  } catch (const MapStorageError& e) {
    fail_writing(e.what());
    return 0;
  }
  map::pb::Observation record;
  std::string frame;
  std::uint64_t end = journal_size_;
  std::size_t written = 0;
  std::string error;
  for (const MapObservation* o : batch) {
    record.set_session(o->session);
    record.set_sequence(o->sequence);
    record.set_t(o->t);
    record.set_lowest_unacked(o->lowest_unacked);
    to_floats(o->points, *record.mutable_xyz());
    frame.clear();
    record_file::append_frame(frame, record.SerializeAsString());
    try {
      record_file::write_all(fd, frame, journal);
    } catch (const MapStorageError& e) {
      error = e.what();
      break;
    }
    end += frame.size();
    ++written;
  }
  if (written > 0 && fsync_ && ::fdatasync(fd) != 0) {
    // What the kernel failed to write may be gone while the pages read back fine: none of the
    // batch can be trusted to be on disk.
    error = "cannot fsync " + journal.string() + ": " + std::strerror(errno);
    written = 0;
    end = journal_size_;
  }
  if (written < batch.size() && ::ftruncate(fd, static_cast<off_t>(end)) != 0) {
    // The next open_journal() rolls it back before anything is appended.
    error += "; rolling back to byte " + std::to_string(end) + " failed: " + std::strerror(errno);
  }
  ::close(fd);
  journal_size_ = end;
  journal_records_ += written;
  if (!error.empty()) fail_writing(error);
  return written;
}

void MapStorage::append(const MapObservation& observation) {
  if (!writable_ && loaded_ && access_ == Access::kReadWrite) make_writable();
  if (append(std::vector<const MapObservation*>{&observation}) != 1) {
    throw MapStorageError(write_error_.empty() ? journal_path().string() + ": not writable" : write_error_);
  }
}

void MapStorage::snapshot(const PointMap& map, const MapMeta& meta) {
  if (access_ != Access::kReadWrite || !loaded_) {
    throw std::logic_error("MapStorage::snapshot needs a read-write storage after load()");
  }
  // The load's repairs come first (an unreadable snapshot is moved aside, not overwritten).
  if (!writable_ && !make_writable()) throw MapStorageError(write_error_);
  if (snapshot_damaged_) {
    keep_beside(snapshot_path(), ".bad", fsync_);
    snapshot_damaged_ = false;
  }
  write_snapshot_file(snapshot_path(), map, meta, fsync_);
  // A crash or a failure from here on leaves journal records the snapshot holds: load() skips them.
  if (journal_damaged_) {
    keep_beside(journal_path(), ".bad", fsync_);
    journal_damaged_ = false;
  }
  reset_journal();
  // The fresh journal needs none of the load's repairs.
  repairs_.journal_cut = 0;
  repairs_.journal_aside = false;
  repairs_.journal_create = false;
}

}  // namespace fuse

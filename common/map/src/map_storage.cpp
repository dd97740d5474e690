#include "fuse/map/map_storage.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
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

std::string at(const fs::path& file, std::uint64_t offset) {
  return file.string() + ": byte " + std::to_string(offset) + ": ";
}

/// What went wrong with a record that next() did not return as kOk.
std::string describe(const FrameReader& reader, FrameStatus status) {
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
  for (const auto& s : header.applied()) meta.applied[s.session()] = s.sequence();
  return meta;
}

}  // namespace

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
      << " already in the snapshot), " << journal_bytes_cut << " bad bytes cut";
  }
  s << "; " << problems.size() << " problem" << (problems.size() == 1 ? "" : "s");
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
  for (const auto& [session, sequence] : meta.applied) {
    map::pb::SessionSequence* s = header.add_applied();
    s->set_session(session);
    s->set_sequence(sequence);
  }
  header.set_epoch(meta.epoch);
  header.set_observations(meta.observations);
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
  bool truncated = false;
  for (;;) {
    const FrameStatus st = reader.next(payload);
    if (st == FrameStatus::kEnd) break;
    if (st == FrameStatus::kTruncated) {
      report.problems.push_back(at(file, reader.frame_offset()) + "chunk record " + describe(reader, st) + ": dropped");
      ++report.chunks_dropped;
      truncated = true;
      break;
    }
    if (st == FrameStatus::kBadCrc) {
      report.problems.push_back(at(file, reader.frame_offset()) + "chunk record " + describe(reader, st) + ": dropped");
      ++report.chunks_dropped;
      continue;
    }
    PointChunk chunk;
    const bool parsed = record.ParseFromString(payload) && record.xyz_size() % 3 == 0;
    if (parsed) {
      chunk.key = record.key();
      chunk.coord = Eigen::Vector3i(record.ix(), record.iy(), record.iz());
      chunk.revision = record.revision();
      chunk.points = from_floats(record.xyz());
    }
    if (!parsed || !loaded.put_chunk(std::move(chunk))) {
      report.problems.push_back(at(file, reader.frame_offset()) + "chunk record is not a valid chunk: dropped");
      ++report.chunks_dropped;
      continue;
    }
    ++report.chunks_loaded;
  }
  const std::uint64_t seen = report.chunks_loaded + report.chunks_dropped;
  if (header.chunk_count() > seen) {
    if (!truncated) {
      report.problems.push_back(at(file, reader.offset()) + "file ends after " + std::to_string(seen) + " of " +
                                std::to_string(header.chunk_count()) + " chunk records (truncated)");
    }
    report.chunks_dropped = header.chunk_count() - report.chunks_loaded;
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
  std::error_code ec;
  fs::create_directories(directory_, ec);
  if (ec) throw MapStorageError("cannot create map directory " + directory_.string() + ": " + ec.message());
  const fs::path lock = directory_ / "map.lock";
  lock_fd_ = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lock_fd_ < 0) throw MapStorageError("cannot open " + lock.string() + ": " + std::strerror(errno));
  if (::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    ::close(lock_fd_);
    lock_fd_ = -1;
    throw MapStorageError("map directory " + directory_.string() + " is in use by another process (" +
                          std::strerror(err) + ")");
  }
}

MapStorage::~MapStorage() {
  close_journal();
  if (lock_fd_ >= 0) ::close(lock_fd_);
}

void MapStorage::close_journal() {
  if (journal_fd_ >= 0) ::close(journal_fd_);
  journal_fd_ = -1;
}

void MapStorage::open_journal_for_append() {
  close_journal();
  journal_fd_ = ::open(journal_path().c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
  if (journal_fd_ < 0) throw MapStorageError("cannot open " + journal_path().string() + ": " + std::strerror(errno));
}

void MapStorage::reset_journal() {
  close_journal();
  record_file::write_atomically(
      journal_path(), [](record_file::FileWriter& w) { w.write(record_file::file_header(kJournalMagic, kFormatVersion)); },
      fsync_);
  journal_size_ = record_file::kFileHeaderSize;
  journal_records_ = 0;
  open_journal_for_append();
}

LoadReport MapStorage::load(PointMap& map, MapMeta& meta, const ReplayFn& replay) {
  if (loaded_) throw std::logic_error("MapStorage::load called twice");
  const bool writable = access_ == Access::kReadWrite;
  map = PointMap(map.chunk_size());
  meta = MapMeta{};
  LoadReport report;
  if (writable) {
    // Leftovers of a write interrupted before its rename: never part of the map.
    for (const char* name : {kSnapshotName, kJournalName}) {
      std::error_code ec;
      fs::remove(directory_ / (std::string(name) + ".tmp"), ec);
    }
  }
  const fs::path snapshot = snapshot_path();
  std::error_code ec;
  if (fs::exists(snapshot, ec)) {
    report = read_snapshot_file(snapshot, map, meta);
    if (!report.snapshot_ok) {
      std::string what = "snapshot unreadable: starting from the journal only";
      if (writable) {
        const fs::path aside = record_file::free_side_name(fs::path(snapshot.string() + ".bad"));
        if (::rename(snapshot.c_str(), aside.c_str()) != 0) {
          throw MapStorageError("cannot move " + snapshot.string() + " aside: " + std::strerror(errno));
        }
        what += " (moved aside to " + aside.filename().string() + ")";
      }
      report.problems.push_back(snapshot.string() + ": " + what);
    }
  }
  load_journal(meta, replay, report);
  loaded_ = true;
  return report;
}

void MapStorage::load_journal(MapMeta& meta, const ReplayFn& replay, LoadReport& report) {
  const bool writable = access_ == Access::kReadWrite;
  const fs::path journal = journal_path();
  std::error_code ec;
  report.journal_found = fs::exists(journal, ec);
  if (!report.journal_found) {
    if (writable) reset_journal();
    return;
  }
  FrameReader reader(journal);
  if (!reader.is_open()) throw MapStorageError("cannot read " + journal.string());
  std::uint32_t version = 0;
  if (!reader.read_file_header(kJournalMagic, version) || version != kFormatVersion) {
    std::string what = "not a map journal of format " + std::to_string(kFormatVersion) + ": no record replayed";
    if (writable) {
      const fs::path aside = record_file::free_side_name(fs::path(journal.string() + ".bad"));
      if (::rename(journal.c_str(), aside.c_str()) != 0) {
        throw MapStorageError("cannot move " + journal.string() + " aside: " + std::strerror(errno));
      }
      what += " (moved aside to " + aside.filename().string() + ", journal restarted)";
      reset_journal();
    }
    report.problems.push_back(at(journal, 0) + what);
    return;
  }

  std::uint64_t good_end = reader.offset();
  std::size_t records = 0;
  std::string payload;
  map::pb::Observation record;
  MapObservation observation;
  for (;;) {
    const FrameStatus st = reader.next(payload);
    if (st == FrameStatus::kEnd) break;
    if (st != FrameStatus::kOk || !record.ParseFromString(payload) || record.xyz_size() % 3 != 0) {
      const std::string what = st == FrameStatus::kOk ? "record does not parse as an observation" : "record " + describe(reader, st);
      report.problems.push_back(at(journal, reader.frame_offset()) + what + ": journal " +
                                (writable ? "cut" : "ignored") + " from here (" +
                                std::to_string(reader.file_size() - good_end) + " bytes)");
      break;
    }
    ++records;
    good_end = reader.offset();
    const auto it = meta.applied.find(record.session());
    if (it != meta.applied.end() && record.sequence() <= it->second) {
      ++report.journal_skipped;
      continue;
    }
    meta.applied[record.session()] = record.sequence();
    ++meta.observations;
    ++report.journal_replayed;
    observation.session = record.session();
    observation.sequence = record.sequence();
    observation.t = record.t();
    observation.points = from_floats(record.xyz());
    replay(observation);
  }
  report.journal_records = records;
  report.journal_bytes_cut = reader.file_size() - good_end;
  journal_records_ = records;
  journal_size_ = good_end;
  if (!writable) return;
  if (report.journal_bytes_cut > 0) {
    const fs::path side = record_file::free_side_name(fs::path(journal.string() + ".cut"));
    copy_tail(journal, good_end, side, fsync_);
    truncate_file(journal, good_end, fsync_);
    report.problems.back() += ", kept in " + side.filename().string();
  }
  open_journal_for_append();
}

void MapStorage::append(const MapObservation& observation) {
  if (access_ != Access::kReadWrite || !loaded_) {
    throw std::logic_error("MapStorage::append needs a read-write storage after load()");
  }
  if (journal_fd_ < 0) throw MapStorageError(journal_path().string() + ": unusable after a failed write");
  map::pb::Observation record;
  record.set_session(observation.session);
  record.set_sequence(observation.sequence);
  record.set_t(observation.t);
  to_floats(observation.points, *record.mutable_xyz());
  std::string frame;
  record_file::append_frame(frame, record.SerializeAsString());
  try {
    record_file::write_all(journal_fd_, frame, journal_path());
    if (fsync_ && ::fdatasync(journal_fd_) != 0) {
      throw MapStorageError("cannot fsync " + journal_path().string() + ": " + std::strerror(errno));
    }
  } catch (const MapStorageError&) {
    // Roll back a partial record so that later appends follow good data.
    if (::ftruncate(journal_fd_, static_cast<off_t>(journal_size_)) != 0) close_journal();
    throw;
  }
  journal_size_ += frame.size();
  ++journal_records_;
}

void MapStorage::snapshot(const PointMap& map, const MapMeta& meta) {
  if (access_ != Access::kReadWrite || !loaded_) {
    throw std::logic_error("MapStorage::snapshot needs a read-write storage after load()");
  }
  write_snapshot_file(snapshot_path(), map, meta, fsync_);
  // A crash here leaves journal records the snapshot holds: load() skips them.
  reset_journal();
}

}  // namespace fuse

// Framed record files (private to fuse_map_storage): a 12-byte file header (8-byte magic, u32
// version), then records [u32 length][u32 crc32 of the bytes][bytes], little-endian. The reader
// tells a clean end from a truncated or corrupted record, with byte offsets for the report, and
// after a bad record finds the next good one again (resync); the writer is a POSIX file with
// explicit fsync, plus the atomic-replace and directory-sync steps.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

namespace fuse::record_file {

constexpr std::size_t kMagicSize = 8;
constexpr std::size_t kFileHeaderSize = kMagicSize + 4;
constexpr std::size_t kFrameHeaderSize = 8;
/// Longest record resync() accepts as a candidate: far above any record written (an observation
/// of 262144 points is 3 MiB, a published chunk at most 12 MiB), so that a damaged length that
/// happens to fit in a large file does not cost a CRC over gigabytes.
constexpr std::uint32_t kMaxResyncRecordBytes = 64u << 20;

/// The file header: magic (exactly kMagicSize characters) and version.
std::string file_header(const char* magic, std::uint32_t version);
/// Appends one framed record holding payload to out.
void append_frame(std::string& out, const std::string& payload);

enum class FrameStatus {
  kOk,
  kEnd,        ///< clean end of file
  kTruncated,  ///< the frame header or the bytes it announces run past the end of the file
  kBadCrc      ///< complete frame whose bytes do not match the CRC
};

class FrameReader {
 public:
  explicit FrameReader(const std::filesystem::path& file);
  ~FrameReader();
  FrameReader(const FrameReader&) = delete;
  FrameReader& operator=(const FrameReader&) = delete;

  bool is_open() const { return fd_ >= 0; }
  std::uint64_t file_size() const { return size_; }

  /// Reads the file header; false when it is short or its magic differs. version receives it.
  bool read_file_header(const char* magic, std::uint32_t& version);
  /// Reads the next record into payload (kBadCrc: the reader has moved past the frame as framed).
  FrameStatus next(std::string& payload);
  /// Start of the record last returned by next() (where a cut goes).
  std::uint64_t frame_offset() const { return frame_offset_; }
  std::uint32_t frame_length() const { return frame_length_; }
  /// Where the next record starts.
  std::uint64_t offset() const { return offset_; }

  using Validator = std::function<bool(const std::string& payload)>;
  /// After a bad record: searches forward from one byte past the start of the record last
  /// returned by next() for the first offset where a frame fits in the file (at most
  /// kMaxResyncRecordBytes), its payload starts with first_byte, matches its CRC and valid()
  /// accepts it. True: next() returns that record. False: none before the end (positioned there).
  /// The length alone is not trusted: a damaged length would skip good records.
  bool resync(char first_byte, const Validator& valid);

 private:
  /// Reads n bytes at offset (false on a read error or past the end).
  bool read_at(std::uint64_t offset, char* out, std::size_t n) const;
  /// n bytes at offset through a read-ahead window (sequential scans read each block once).
  const char* window(std::uint64_t offset, std::size_t n);

  int fd_ = -1;
  std::uint64_t size_ = 0;
  std::uint64_t offset_ = 0;
  std::uint64_t frame_offset_ = 0;
  std::uint32_t frame_length_ = 0;
  std::string window_;
  std::uint64_t window_offset_ = 0;
};

/// A file written through a POSIX descriptor; every failure throws MapStorageError naming it.
class FileWriter {
 public:
  FileWriter(const std::filesystem::path& file, int open_flags);
  ~FileWriter();
  FileWriter(const FileWriter&) = delete;
  FileWriter& operator=(const FileWriter&) = delete;

  void write(const std::string& bytes);
  void sync();
  void close();

 private:
  std::filesystem::path file_;
  int fd_ = -1;
};

/// Writes all bytes to fd (retrying short writes and EINTR); throws MapStorageError naming file.
void write_all(int fd, const std::string& bytes, const std::filesystem::path& file);
/// fsyncs a directory, so that a rename or a new entry in it is durable.
void sync_directory(const std::filesystem::path& dir);
/// Replaces file atomically: body writes a temp file beside it, which is fsync'd (when fsync),
/// renamed over file, and the directory fsync'd. The temp file is removed on failure.
void write_atomically(const std::filesystem::path& file, const std::function<void(FileWriter&)>& body, bool fsync);
/// The first of base.1, base.2, ... that does not exist.
std::filesystem::path free_side_name(const std::filesystem::path& base);

}  // namespace fuse::record_file

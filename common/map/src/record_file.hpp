// Framed record files (private to fuse_map_storage): a 12-byte file header (8-byte magic, u32
// version), then records [u32 length][u32 crc32 of the bytes][bytes], little-endian. The reader
// tells a clean end from a truncated or corrupted record, with byte offsets for the report; the
// writer is a POSIX file with explicit fsync, plus the atomic-replace and directory-sync steps.
#pragma once

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

namespace fuse::record_file {

constexpr std::size_t kMagicSize = 8;
constexpr std::size_t kFileHeaderSize = kMagicSize + 4;
constexpr std::size_t kFrameHeaderSize = 8;

/// The file header: magic (exactly kMagicSize characters) and version.
std::string file_header(const char* magic, std::uint32_t version);
/// Appends one framed record holding payload to out.
void append_frame(std::string& out, const std::string& payload);

enum class FrameStatus {
  kOk,
  kEnd,        ///< clean end of file
  kTruncated,  ///< the frame header or the bytes it announces run past the end of the file
  kBadCrc      ///< complete frame whose bytes do not match the CRC (reader moved past it)
};

class FrameReader {
 public:
  explicit FrameReader(const std::filesystem::path& file);
  bool is_open() const { return in_.is_open(); }
  std::uint64_t file_size() const { return size_; }

  /// Reads the file header; false when it is short or its magic differs. version receives it.
  bool read_file_header(const char* magic, std::uint32_t& version);
  /// Reads the next record into payload.
  FrameStatus next(std::string& payload);
  /// Start of the record last returned by next() (where a cut goes).
  std::uint64_t frame_offset() const { return frame_offset_; }
  std::uint32_t frame_length() const { return frame_length_; }
  /// Where the next record starts.
  std::uint64_t offset() const { return offset_; }

 private:
  std::ifstream in_;
  std::uint64_t size_ = 0;
  std::uint64_t offset_ = 0;
  std::uint64_t frame_offset_ = 0;
  std::uint32_t frame_length_ = 0;
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

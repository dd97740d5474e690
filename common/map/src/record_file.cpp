#include "record_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <system_error>

#include "fuse/io/crc32.hpp"
#include "fuse/map/map_storage.hpp"

namespace fuse::record_file {

namespace {

void put_u32(std::string& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFFu));
}

std::uint32_t get_u32(const char* p) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(static_cast<unsigned char>(p[i])) << (8 * i);
  return v;
}

[[noreturn]] void fail(const std::string& what, const std::filesystem::path& file, int err) {
  throw MapStorageError(what + " " + file.string() + ": " + std::strerror(err));
}

}  // namespace

std::string file_header(const char* magic, std::uint32_t version) {
  std::string out(magic, kMagicSize);
  put_u32(out, version);
  return out;
}

void append_frame(std::string& out, const std::string& payload) {
  put_u32(out, static_cast<std::uint32_t>(payload.size()));
  put_u32(out, io::crc32(payload.data(), payload.size()));
  out += payload;
}

FrameReader::FrameReader(const std::filesystem::path& file) : in_(file, std::ios::binary) {
  if (!in_.is_open()) return;
  std::error_code ec;
  size_ = std::filesystem::file_size(file, ec);
  if (ec) in_.close();
}

bool FrameReader::read_file_header(const char* magic, std::uint32_t& version) {
  char header[kFileHeaderSize];
  if (size_ < kFileHeaderSize || !in_.read(header, kFileHeaderSize)) return false;
  offset_ = kFileHeaderSize;
  version = get_u32(header + kMagicSize);
  return std::memcmp(header, magic, kMagicSize) == 0;
}

FrameStatus FrameReader::next(std::string& payload) {
  frame_offset_ = offset_;
  frame_length_ = 0;
  if (offset_ == size_) return FrameStatus::kEnd;
  char header[kFrameHeaderSize];
  if (size_ - offset_ < kFrameHeaderSize || !in_.read(header, kFrameHeaderSize)) return FrameStatus::kTruncated;
  frame_length_ = get_u32(header);
  const std::uint32_t crc = get_u32(header + 4);
  // The length is checked against what is left before allocating: a corrupted length then
  // reads as a truncated file instead of a huge allocation.
  if (frame_length_ > size_ - offset_ - kFrameHeaderSize) return FrameStatus::kTruncated;
  payload.resize(frame_length_);
  if (frame_length_ > 0 && !in_.read(payload.data(), frame_length_)) return FrameStatus::kTruncated;
  offset_ += kFrameHeaderSize + frame_length_;
  return io::crc32(payload.data(), payload.size()) == crc ? FrameStatus::kOk : FrameStatus::kBadCrc;
}

FileWriter::FileWriter(const std::filesystem::path& file, int open_flags) : file_(file) {
  fd_ = ::open(file.c_str(), open_flags | O_CLOEXEC, 0644);
  if (fd_ < 0) fail("cannot open", file_, errno);
}

FileWriter::~FileWriter() {
  if (fd_ >= 0) ::close(fd_);
}

void FileWriter::write(const std::string& bytes) { write_all(fd_, bytes, file_); }

void FileWriter::sync() {
  if (::fsync(fd_) != 0) fail("cannot fsync", file_, errno);
}

void FileWriter::close() {
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) fail("cannot close", file_, errno);
}

void write_all(int fd, const std::string& bytes, const std::filesystem::path& file) {
  const char* p = bytes.data();
  std::size_t left = bytes.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("cannot write", file, errno);
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
}

void sync_directory(const std::filesystem::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) fail("cannot open directory", dir, errno);
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0) fail("cannot fsync directory", dir, err);
}

void write_atomically(const std::filesystem::path& file, const std::function<void(FileWriter&)>& body, bool fsync) {
  std::filesystem::path tmp = file;
  tmp += ".tmp";
  try {
    FileWriter writer(tmp, O_WRONLY | O_CREAT | O_TRUNC);
    body(writer);
    if (fsync) writer.sync();
    writer.close();
    if (::rename(tmp.c_str(), file.c_str()) != 0) fail("cannot rename into", file, errno);
  } catch (...) {
    ::unlink(tmp.c_str());
    throw;
  }
  if (fsync) sync_directory(file.has_parent_path() ? file.parent_path() : std::filesystem::path("."));
}

std::filesystem::path free_side_name(const std::filesystem::path& base) {
  for (int i = 1;; ++i) {
    std::filesystem::path candidate = base;
    candidate += "." + std::to_string(i);
    std::error_code ec;
    if (!std::filesystem::exists(candidate, ec)) return candidate;
  }
}

}  // namespace fuse::record_file

#include "record_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <system_error>

#include "fuse/io/crc32.hpp"
#include "fuse/map/map_storage.hpp"

namespace fuse::record_file {

namespace {

/// Bytes resync() reads ahead at a time.
constexpr std::uint64_t kWindowBytes = 1u << 20;

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

FrameReader::FrameReader(const std::filesystem::path& file) {
  fd_ = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) return;
  struct stat st {};
  if (::fstat(fd_, &st) != 0) {
    ::close(fd_);
    fd_ = -1;
    return;
  }
  size_ = static_cast<std::uint64_t>(st.st_size);
}

FrameReader::~FrameReader() {
  if (fd_ >= 0) ::close(fd_);
}

bool FrameReader::read_at(std::uint64_t offset, char* out, std::size_t n) const {
  if (offset > size_ || n > size_ - offset) return false;
  while (n > 0) {
    const ssize_t got = ::pread(fd_, out, n, static_cast<off_t>(offset));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) return false;
    out += got;
    offset += static_cast<std::uint64_t>(got);
    n -= static_cast<std::size_t>(got);
  }
  return true;
}

const char* FrameReader::window(std::uint64_t offset, std::size_t n) {
  if (offset < window_offset_ || offset + n > window_offset_ + window_.size()) {
    const std::uint64_t want = std::max<std::uint64_t>(n, kWindowBytes);
    window_.resize(static_cast<std::size_t>(std::min<std::uint64_t>(want, size_ - std::min(offset, size_))));
    window_offset_ = offset;
    if (window_.size() < n || !read_at(offset, window_.data(), window_.size())) {
      window_.clear();
      return nullptr;
    }
  }
  return window_.data() + (offset - window_offset_);
}

bool FrameReader::read_file_header(const char* magic, std::uint32_t& version) {
  char header[kFileHeaderSize];
  if (!read_at(0, header, kFileHeaderSize)) return false;
  offset_ = kFileHeaderSize;
  version = get_u32(header + kMagicSize);
  return std::memcmp(header, magic, kMagicSize) == 0;
}

FrameStatus FrameReader::next(std::string& payload) {
  frame_offset_ = offset_;
  frame_length_ = 0;
  if (offset_ == size_) return FrameStatus::kEnd;
  char header[kFrameHeaderSize];
  if (!read_at(offset_, header, kFrameHeaderSize)) return FrameStatus::kTruncated;
  frame_length_ = get_u32(header);
  const std::uint32_t crc = get_u32(header + 4);
  // The length is checked against what is left before allocating: a corrupted length then
  // reads as a truncated file instead of a huge allocation.
  if (frame_length_ > size_ - offset_ - kFrameHeaderSize) return FrameStatus::kTruncated;
  payload.resize(frame_length_);
  if (!read_at(offset_ + kFrameHeaderSize, payload.data(), frame_length_)) return FrameStatus::kTruncated;
  offset_ += kFrameHeaderSize + frame_length_;
  return io::crc32(payload.data(), payload.size()) == crc ? FrameStatus::kOk : FrameStatus::kBadCrc;
}

bool FrameReader::resync(char first_byte, const Validator& valid) {
  std::string payload;
  for (std::uint64_t at = frame_offset_ + 1; at + kFrameHeaderSize < size_; ++at) {
    const char* header = window(at, kFrameHeaderSize + 1);
    if (header == nullptr) break;
    // Cheap tests first: the length must fit, the payload start with the record's first tag.
    const std::uint32_t length = get_u32(header);
    if (length == 0 || length > kMaxResyncRecordBytes || length > size_ - at - kFrameHeaderSize) continue;
    if (header[kFrameHeaderSize] != first_byte) continue;
    const std::uint32_t crc = get_u32(header + 4);
    const char* bytes = window(at + kFrameHeaderSize, length);
    if (bytes == nullptr || io::crc32(bytes, length) != crc) continue;
    payload.assign(bytes, length);
    if (!valid(payload)) continue;
    offset_ = at;
    return true;
  }
  offset_ = size_;
  return false;
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

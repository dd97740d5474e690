#include "fuse/service/state_checkpoint.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>

#include "fuse/core/counters.hpp"
#include "fuse/core/logging.hpp"
#include "fuse/io/crc32.hpp"
#include "fuse/transport/msg_traits.hpp"

namespace fuse::service {

namespace {
constexpr char kMagic[8] = {'F', 'U', 'S', 'E', 'S', 'C', 'K', 'P'};
constexpr std::uint32_t kVersion = 3;  // 2: the Correction carries its world frame; 3: the time offset (24-dim state)
constexpr std::size_t kHeaderSize = sizeof(kMagic) + 3 * sizeof(std::uint32_t);

void put_u32(std::string& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFFu));
}
std::uint32_t get_u32(const char* p) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(static_cast<unsigned char>(p[i])) << (8 * i);
  return v;
}
}  // namespace

std::optional<Checkpoint> read_checkpoint(const std::filesystem::path& file, std::string& why) {
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    why = "no checkpoint at " + file.string();
    return std::nullopt;
  }
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() < kHeaderSize || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) {
    why = file.string() + " is not a fuse-state checkpoint";
    return std::nullopt;
  }
  const char* h = bytes.data() + sizeof(kMagic);
  if (get_u32(h) != kVersion) {
    why = file.string() + ": checkpoint format version " + std::to_string(get_u32(h)) + ", this fuse-state reads " +
          std::to_string(kVersion);
    return std::nullopt;
  }
  const std::uint32_t length = get_u32(h + 4), crc = get_u32(h + 8);
  if (length != bytes.size() - kHeaderSize || io::crc32(bytes.data() + kHeaderSize, length) != crc) {
    why = file.string() + ": checkpoint damaged (length or CRC mismatch)";
    return std::nullopt;
  }
  constexpr std::size_t kDriftBytes = 36 * sizeof(double);
  if (length < kDriftBytes) {
    why = file.string() + ": checkpoint too short";
    return std::nullopt;
  }
  const char* payload = bytes.data() + kHeaderSize;
  const std::size_t message_length = length - kDriftBytes;
  fuse_msgs::Correction msg;
  std::string error;
  if (!transport::deserialize(reinterpret_cast<const std::uint8_t*>(payload), message_length, msg, &error)) {
    why = file.string() + ": " + error;
    return std::nullopt;
  }
  Checkpoint c;
  try {
    c.posterior = from_msg(msg);
    c.frame = frame_of(msg);
  } catch (const InvalidSample& e) {
    why = file.string() + ": " + e.what();
    return std::nullopt;
  }
  for (int i = 0; i < 36; ++i) {
    std::uint64_t bits = 0;
    for (int b = 0; b < 8; ++b) bits |= std::uint64_t{static_cast<unsigned char>(payload[message_length + 8 * i + b])} << (8 * b);
    double v;
    std::memcpy(&v, &bits, sizeof v);
    c.map_drift(i / 6, i % 6) = v;
  }
  if (!c.map_drift.allFinite()) {
    why = file.string() + ": map drift is not finite";
    return std::nullopt;
  }
  return c;
}

void write_checkpoint(const std::filesystem::path& file, const Checkpoint& checkpoint) {
  fuse_msgs::Correction msg = to_msg(checkpoint.posterior);
  msg.map_frame(checkpoint.frame.state);
  msg.frame_epoch(checkpoint.frame.epoch);
  transport::Bytes payload = transport::serialize(msg);
  for (int i = 0; i < 36; ++i) {
    std::uint64_t bits = 0;
    const double v = checkpoint.map_drift(i / 6, i % 6);
    std::memcpy(&bits, &v, sizeof v);
    for (int b = 0; b < 8; ++b) payload.push_back(static_cast<std::uint8_t>((bits >> (8 * b)) & 0xFFu));
  }
  std::string bytes(kMagic, sizeof(kMagic));
  put_u32(bytes, kVersion);
  put_u32(bytes, static_cast<std::uint32_t>(payload.size()));
  put_u32(bytes, io::crc32(payload.data(), payload.size()));
  bytes.append(reinterpret_cast<const char*>(payload.data()), payload.size());
  // Written to a side file, flushed to the device, renamed over the old one, and the directory
  // flushed: after a power loss the checkpoint is the old or the new one, never a torn or empty
  // file that a rename ahead of the data would leave.
  std::filesystem::path tmp = file;
  tmp += ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("cannot write checkpoint " + tmp.string() + ": " + std::strerror(errno));
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = errno;
      ::close(fd);
      throw std::runtime_error("cannot write checkpoint " + tmp.string() + ": " + std::strerror(err));
    }
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    throw std::runtime_error("cannot flush checkpoint " + tmp.string() + ": " + std::strerror(err));
  }
  ::close(fd);
  std::error_code ec;
  std::filesystem::rename(tmp, file, ec);
  if (ec) throw std::runtime_error("cannot rename checkpoint into " + file.string() + ": " + ec.message());
  const std::filesystem::path dir = file.has_parent_path() ? file.parent_path() : std::filesystem::path(".");
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {  // a directory that cannot be opened for flushing still holds the renamed file
    const int rc = ::fsync(dfd);
    const int err = errno;
    ::close(dfd);
    if (rc != 0) throw std::runtime_error("cannot flush directory " + dir.string() + ": " + std::strerror(err));
  }
}

CheckpointWriter::CheckpointWriter(std::filesystem::path file, double period_s)
    : file_(std::move(file)), period_(period_s), thread_([this] { run(); }) {}

CheckpointWriter::~CheckpointWriter() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

void CheckpointWriter::offer(const Checkpoint& checkpoint) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (pending_ && pending_->posterior.t > checkpoint.posterior.t) return;
    pending_ = checkpoint;
  }
  cv_.notify_all();
}

std::uint64_t CheckpointWriter::written() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return written_;
}
std::uint64_t CheckpointWriter::failures() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return failures_;
}
std::string CheckpointWriter::last_error() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return last_error_;
}

void CheckpointWriter::run() {
  LogRateLimit limit;
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    cv_.wait(lock, [this] { return stop_ || pending_.has_value(); });
    if (!pending_) return;  // stopping with nothing left to write
    const Checkpoint checkpoint = *pending_;
    pending_.reset();
    lock.unlock();
    std::string error;
    try {
      write_checkpoint(file_, checkpoint);
    } catch (const std::exception& e) {
      error = e.what();
    }
    lock.lock();
    if (error.empty()) {
      ++written_;
    } else {
      ++failures_;
      last_error_ = error;
      std::uint64_t suppressed = 0;
      if (limit.allow(suppressed)) {
        logger("fuse-state")->warn("checkpoint not written: {} ({} failures{})", error, failures_,
                                   suppressed ? ", " + std::to_string(suppressed) + " not logged" : "");
      }
    }
    if (stop_) continue;  // write what is pending, then stop
    cv_.wait_for(lock, period_, [this] { return stop_; });
  }
}

}  // namespace fuse::service

#include "fuse/service/state_checkpoint.hpp"

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
constexpr std::uint32_t kVersion = 1;
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

std::optional<Posterior> read_checkpoint(const std::filesystem::path& file, std::string& why) {
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
  fuse_msgs::Correction msg;
  std::string error;
  if (!transport::deserialize(reinterpret_cast<const std::uint8_t*>(bytes.data() + kHeaderSize), length, msg, &error)) {
    why = file.string() + ": " + error;
    return std::nullopt;
  }
  try {
    return from_msg(msg);
  } catch (const InvalidSample& e) {
    why = file.string() + ": " + e.what();
    return std::nullopt;
  }
}

void write_checkpoint(const std::filesystem::path& file, const Posterior& posterior) {
  const transport::Bytes payload = transport::serialize(to_msg(posterior));
  std::string bytes(kMagic, sizeof(kMagic));
  put_u32(bytes, kVersion);
  put_u32(bytes, static_cast<std::uint32_t>(payload.size()));
  put_u32(bytes, io::crc32(payload.data(), payload.size()));
  bytes.append(reinterpret_cast<const char*>(payload.data()), payload.size());
  std::filesystem::path tmp = file;
  tmp += ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) throw std::runtime_error("cannot write checkpoint " + tmp.string() + ": " + std::strerror(errno));
  }
  std::error_code ec;
  std::filesystem::rename(tmp, file, ec);
  if (ec) throw std::runtime_error("cannot rename checkpoint into " + file.string() + ": " + ec.message());
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

void CheckpointWriter::offer(const Posterior& posterior) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (pending_ && pending_->t > posterior.t) return;
    pending_ = posterior;
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
    const Posterior posterior = *pending_;
    pending_.reset();
    lock.unlock();
    std::string error;
    try {
      write_checkpoint(file_, posterior);
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

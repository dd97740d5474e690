#include "fuse/io/livox_udp_source.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include "fuse/core/logging.hpp"

namespace fuse::io {
namespace {

/// How often the receiver thread looks at the stop flag.
constexpr int kPollTimeoutMs = 50;
/// Largest UDP payload; one more byte shows a datagram that was cut.
constexpr std::size_t kMaxDatagram = 65535;
/// Receive buffer asked of the kernel: bursts of point packets at ~100 Mbit/s.
constexpr int kSocketBufferBytes = 4 << 20;

int open_socket(const std::string& address, std::uint16_t port, std::uint16_t& bound, const char* what) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw InputError(std::string("Livox ") + what + " socket: " + std::strerror(errno));
  // No SO_REUSEADDR: a port another socket holds must fail here, not be silently shared.
  ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &kSocketBufferBytes, sizeof(kSocketBufferBytes));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  if (::inet_pton(AF_INET, address.c_str(), &addr.sin_addr) != 1) {
    ::close(fd);
    throw InputError("Livox input: '" + address + "' is not an IPv4 address");
  }
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    const std::string err = std::strerror(errno);
    ::close(fd);
    throw InputError(std::string("Livox ") + what + " port " + address + ":" + std::to_string(port) + ": " + err);
  }
  socklen_t len = sizeof(addr);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  bound = ntohs(addr.sin_port);
  return fd;
}

}  // namespace

LivoxUdpSource::LivoxUdpSource(const LivoxUdpConfig& config)
    : config_(config), assembler_(config.scan_period_s), validator_("Livox UDP") {
  if (config_.queue_capacity == 0) throw InputError("Livox input: queue capacity must be at least 1");
  if (!(config_.idle_timeout_s >= 0.0)) throw InputError("Livox input: idle timeout must be >= 0");
  if (config_.point_port != 0 && config_.point_port == config_.imu_port) {
    throw InputError("Livox input: point data and IMU ports are both " + std::to_string(config_.point_port));
  }
  point_fd_ = open_socket(config_.address, config_.point_port, point_port_, "point data");
  try {
    imu_fd_ = open_socket(config_.address, config_.imu_port, imu_port_, "IMU");
  } catch (...) {
    ::close(point_fd_);
    throw;
  }
  thread_ = std::thread([this] { receive_loop(); });
  logger("livox")->info("listening for Livox point data on {}:{} and IMU on {}:{}", config_.address, point_port_,
                        config_.address, imu_port_);
}

LivoxUdpSource::~LivoxUdpSource() {
  stop();
  if (thread_.joinable()) thread_.join();
  ::close(point_fd_);
  ::close(imu_fd_);
}

void LivoxUdpSource::stop() {
  stop_ = true;
  cv_.notify_all();
}

std::string LivoxUdpSource::describe() const {
  return "Livox UDP (points " + config_.address + ":" + std::to_string(point_port_) + ", IMU " + config_.address + ":" +
         std::to_string(imu_port_) + ")";
}

void LivoxUdpSource::count(const std::string& reason, const std::string& detail, std::uint64_t n) {
  validator_.count(reason, detail, n);
}

void LivoxUdpSource::push(SensorEvent&& ev) {
  if (queue_.size() >= config_.queue_capacity) {
    count(livox_reason::kQueueOverflow, "event queue full: dropped");
    return;
  }
  queue_.push_back(std::move(ev));
  cv_.notify_one();
}

void LivoxUdpSource::handle(const std::uint8_t* data, std::size_t size, bool point_port) {
  ++packets_;
  livox::Packet packet;
  livox::DecodeError error;
  const bool ok = livox::decode_packet(data, size, packet, error);
  std::lock_guard<std::mutex> lock(mutex_);
  if (!ok) {
    ++malformed_;
    count(error.reason, error.message);
    return;
  }
  if (packet.header.data_type == static_cast<std::uint8_t>(livox::DataType::kImu)) {
    if (point_port) count(livox_reason::kImuOnPointPort, "IMU packet on the point data port: used");
    SensorEvent ev;
    ev.kind = SensorEvent::Kind::kImu;
    ev.imu = packet.imu;
    ev.imu.sequence = imu_sequence_++;
    push(std::move(ev));
    return;
  }
  std::vector<LidarScan> done;
  assembler_.add(packet.points, done);
  for (auto& scan : done) {
    SensorEvent ev;
    ev.kind = SensorEvent::Kind::kLidar;
    ev.scan = std::move(scan);
    push(std::move(ev));
  }
  if (assembler_.late_points() > late_reported_) {
    count(livox_reason::kLatePoints, "points older than the scan being filled: dropped",
          assembler_.late_points() - late_reported_);
    late_reported_ = assembler_.late_points();
  }
  if (assembler_.empty_returns() > empty_reported_) {
    count(livox_reason::kEmptyReturns, "returns at the origin (no echo): dropped",
          assembler_.empty_returns() - empty_reported_);
    empty_reported_ = assembler_.empty_returns();
  }
}

void LivoxUdpSource::receive_loop() {
  std::vector<std::uint8_t> buffer(kMaxDatagram + 1);
  pollfd fds[2] = {{point_fd_, POLLIN, 0}, {imu_fd_, POLLIN, 0}};
  auto last_packet = std::chrono::steady_clock::now();
  while (!stop_ && !(config_.should_stop && config_.should_stop())) {
    const int n = ::poll(fds, 2, kPollTimeoutMs);
    if (n < 0 && errno != EINTR) {
      logger("livox")->error("poll: {}", std::strerror(errno));
      break;
    }
    bool any = false;
    for (int i = 0; i < 2 && n > 0; ++i) {
      if (!(fds[i].revents & POLLIN)) continue;
      // Drain what is there: a burst of packets is read before the next poll.
      for (;;) {
        const ssize_t got = ::recv(fds[i].fd, buffer.data(), buffer.size(), MSG_DONTWAIT | MSG_TRUNC);
        if (got < 0) break;
        any = true;
        // MSG_TRUNC returns the datagram's real size: a cut datagram fails the length check.
        handle(buffer.data(), std::min<std::size_t>(static_cast<std::size_t>(got), buffer.size()), i == 0);
      }
    }
    const auto now = std::chrono::steady_clock::now();
    if (any) last_packet = now;
    if (config_.idle_timeout_s > 0.0 && std::chrono::duration<double>(now - last_packet).count() > config_.idle_timeout_s) {
      break;
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  // The end of the stream: the scan being filled goes out as it is (ending at its last point).
  if (auto last = assembler_.flush()) {
    SensorEvent ev;
    ev.kind = SensorEvent::Kind::kLidar;
    ev.scan = std::move(*last);
    float span = 0.f;
    for (const auto& p : ev.scan.points) span = std::max(span, p.t_rel);
    ev.scan.t_end = ev.scan.t_start + span;
    push(std::move(ev));
  }
  receiver_done_ = true;
  cv_.notify_all();
}

bool LivoxUdpSource::next(SensorEvent& out) {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    if (!passed_.empty()) {
      out = std::move(passed_.front());
      passed_.pop_front();
      return true;
    }
    cv_.wait(lock, [this] { return !queue_.empty() || receiver_done_; });
    if (queue_.empty()) {
      validator_.finish();
      stats_ = validator_.stats();
      return false;
    }
    SensorEvent event = std::move(queue_.front());
    queue_.pop_front();
    validator_.check(std::move(event), passed_);
    stats_ = validator_.stats();
  }
}

}  // namespace fuse::io

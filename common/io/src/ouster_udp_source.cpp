#include "fuse/io/ouster_udp_source.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include "fuse/core/logging.hpp"
#include "fuse/io/ouster_pcap_source.hpp"

namespace fuse::io {
namespace {

constexpr int kPollTimeoutMs = 50;
constexpr std::size_t kMaxDatagram = 65535;
/// Receive buffer asked of the kernel: a 128-beam dual-return sensor sends ~50 MB/s.
constexpr int kSocketBufferBytes = 8 << 20;
/// Events are held this long (sensor time) to be released in time order.
constexpr double kReorderWindowS = 0.05;

int open_socket(const std::string& address, std::uint16_t port, std::uint16_t& bound, const char* what) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw InputError(std::string("Ouster ") + what + " socket: " + std::strerror(errno));
  ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &kSocketBufferBytes, sizeof(kSocketBufferBytes));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  if (::inet_pton(AF_INET, address.c_str(), &addr.sin_addr) != 1) {
    ::close(fd);
    throw InputError("Ouster input: '" + address + "' is not an IPv4 address");
  }
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    const std::string err = std::strerror(errno);
    ::close(fd);
    throw InputError(std::string("Ouster ") + what + " port " + address + ":" + std::to_string(port) + ": " + err);
  }
  socklen_t len = sizeof(addr);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  bound = ntohs(addr.sin_port);
  return fd;
}

}  // namespace

OusterUdpSource::OusterUdpSource(const OusterUdpConfig& config)
    : config_(config),
      meta_(load_ouster_metadata(config.metadata, config.lidar_port, config.imu_port)),
      validator_("Ouster UDP") {
  if (config_.queue_capacity == 0) throw InputError("Ouster input: queue capacity must be at least 1");
  if (!(config_.idle_timeout_s >= 0.0)) throw InputError("Ouster input: idle timeout must be >= 0");
  // A port of 0 in the metadata switches that stream off; a port of 0 asked here is any free one.
  const bool want_lidar = config_.lidar_port.has_value() || meta_.udp_port_lidar != 0;
  const bool want_imu = config_.imu_port.has_value() || meta_.udp_port_imu != 0;
  const bool shared = want_lidar && want_imu && meta_.udp_port_lidar == meta_.udp_port_imu && meta_.udp_port_lidar != 0;
  if (want_lidar) lidar_fd_ = open_socket(config_.address, meta_.udp_port_lidar, lidar_port_, "lidar");
  if (shared) {
    imu_port_ = lidar_port_;
  } else if (want_imu) {
    try {
      imu_fd_ = open_socket(config_.address, meta_.udp_port_imu, imu_port_, "IMU");
    } catch (...) {
      if (lidar_fd_ >= 0) ::close(lidar_fd_);
      throw;
    }
  }
  // Ports asked as 0 are what the kernel chose: the stream routes by the bound ones.
  meta_.udp_port_lidar = lidar_port_;
  meta_.udp_port_imu = imu_port_;
  stream_ = std::make_unique<ouster::Stream>(meta_, validator_, kReorderWindowS);
  thread_ = std::thread([this] { receive_loop(); });
  logger("ouster")->info("listening for Ouster {} {} lidar packets ({}, {} x {}) on {}:{} and IMU on {}:{}",
                         meta_.prod_line, meta_.serial, ouster::profile_name(meta_.lidar_profile),
                         meta_.pixels_per_column, meta_.window_columns(), config_.address, lidar_port_, config_.address,
                         imu_port_);
}

OusterUdpSource::~OusterUdpSource() {
  stop();
  if (thread_.joinable()) thread_.join();
  if (lidar_fd_ >= 0) ::close(lidar_fd_);
  if (imu_fd_ >= 0) ::close(imu_fd_);
}

void OusterUdpSource::stop() {
  stop_ = true;
  cv_.notify_all();
}

std::string OusterUdpSource::describe() const {
  return "Ouster UDP (lidar " + config_.address + ":" + std::to_string(lidar_port_) + ", IMU " + config_.address + ":" +
         std::to_string(imu_port_) + ", metadata " + config_.metadata + ")";
}

void OusterUdpSource::receive_loop() {
  std::vector<std::uint8_t> buffer(kMaxDatagram + 1);
  pollfd fds[2] = {{lidar_fd_, POLLIN, 0}, {imu_fd_, POLLIN, 0}};
  const std::uint16_t ports[2] = {lidar_port_, imu_port_};
  auto last_packet = std::chrono::steady_clock::now();
  bool held_flushed = true;
  while (!stop_ && !(config_.should_stop && config_.should_stop())) {
    const int n = ::poll(fds, 2, kPollTimeoutMs);  // a negative fd is ignored by poll
    if (n < 0 && errno != EINTR) {
      logger("ouster")->error("poll: {}", std::strerror(errno));
      break;
    }
    bool any = false;
    for (int i = 0; i < 2 && n > 0; ++i) {
      if (fds[i].fd < 0 || !(fds[i].revents & POLLIN)) continue;
      for (;;) {
        sockaddr_in from{};
        socklen_t from_len = sizeof(from);
        const ssize_t got = ::recvfrom(fds[i].fd, buffer.data(), buffer.size(), MSG_DONTWAIT | MSG_TRUNC,
                                       reinterpret_cast<sockaddr*>(&from), &from_len);
        if (got < 0) break;
        any = true;
        ++packets_;
        std::lock_guard<std::mutex> lock(mutex_);
        const std::size_t before = queue_.size();
        // MSG_TRUNC gives the real size: a cut datagram fails the decoder's size check.
        stream_->handle(buffer.data(), std::min<std::size_t>(static_cast<std::size_t>(got), buffer.size()),
                        ntohl(from.sin_addr.s_addr), ports[i], queue_);
        while (queue_.size() > config_.queue_capacity) {
          queue_.pop_front();
          validator_.count("ouster_queue_overflow", "event queue full: the oldest event dropped");
        }
        if (queue_.size() != before) cv_.notify_one();
      }
    }
    const auto now = std::chrono::steady_clock::now();
    if (any) {
      last_packet = now;
      held_flushed = false;
    } else if (!held_flushed && std::chrono::duration<double>(now - last_packet).count() > kReorderWindowS) {
      // Quiet for the reorder window: what is held cannot be overtaken any more, publish it.
      std::lock_guard<std::mutex> lock(mutex_);
      const std::size_t before = queue_.size();
      stream_->release_held(queue_);
      if (queue_.size() != before) cv_.notify_one();
      held_flushed = true;
    }
    if (config_.idle_timeout_s > 0.0 && std::chrono::duration<double>(now - last_packet).count() > config_.idle_timeout_s) {
      break;
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  stream_->finish(queue_);
  receiver_done_ = true;
  cv_.notify_all();
}

bool OusterUdpSource::next(SensorEvent& out) {
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

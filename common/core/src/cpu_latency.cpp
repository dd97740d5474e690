#include "fuse/core/cpu_latency.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <utility>

namespace fuse {

CpuLatencyRequest::CpuLatencyRequest(int latency_us, const std::string& device) {
  if (latency_us < 0 || latency_us > kMaxCpuLatencyUs) {
    throw std::invalid_argument("CPU latency bound " + std::to_string(latency_us) + " us is outside 0.." +
                                std::to_string(kMaxCpuLatencyUs));
  }
  const int fd = ::open(device.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0) {
    message_ = "cannot open " + device + ": " + std::strerror(errno);
    return;
  }
  // The PM QoS device takes the bound as a binary 32-bit integer.
  const std::int32_t value = latency_us;
  if (::write(fd, &value, sizeof(value)) != static_cast<ssize_t>(sizeof(value))) {
    message_ = "cannot write " + device + ": " + std::strerror(errno);
    ::close(fd);
    return;
  }
  fd_ = fd;
}

CpuLatencyRequest::~CpuLatencyRequest() {
  if (fd_ >= 0) ::close(fd_);
}

CpuLatencyRequest::CpuLatencyRequest(CpuLatencyRequest&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), message_(std::move(other.message_)) {}

CpuLatencyRequest& CpuLatencyRequest::operator=(CpuLatencyRequest&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(other.fd_, -1);
    message_ = std::move(other.message_);
  }
  return *this;
}

int cpu_latency_in_force_us(const std::string& device) {
  const int fd = ::open(device.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return -1;
  std::int32_t value = -1;
  const bool ok = ::read(fd, &value, sizeof(value)) == static_cast<ssize_t>(sizeof(value));
  ::close(fd);
  return ok ? value : -1;
}

}  // namespace fuse

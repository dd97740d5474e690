// A CPU wake-up latency request (Linux PM QoS, /dev/cpu_dma_latency).
//
// An idle CPU enters an idle state; leaving it costs time, and in a virtual machine a halted
// virtual CPU also gives its physical CPU (and caches) back to the host. A scan that arrives
// every 100 ms then finds the update's CPU asleep and its caches cold: on a 2-core VM the
// update ran 1.3-1.5x slower inside fuse-update than back to back in fuse-run
// (docs/performance.md). A process that writes a latency bound L (a 32-bit integer, in us) to
// /dev/cpu_dma_latency and keeps the file open makes the kernel use only idle states that
// wake within L; 0 leaves only polling. The kernel keeps the smallest bound of all open requests
// and drops a request when its file is closed, so the bound lives exactly as long as the
// holder. The price is power: CPUs that poll do not sleep.
#pragma once

#include <string>

namespace fuse {

/// Largest bound a request accepts, in microseconds.
inline constexpr int kMaxCpuLatencyUs = 1000000;
/// The device of the system-wide request.
inline constexpr const char* kCpuLatencyDevice = "/dev/cpu_dma_latency";

/// Holds one latency request while the object lives (move-only).
class CpuLatencyRequest {
 public:
  /// Opens `device` and writes `latency_us` (0..kMaxCpuLatencyUs; std::invalid_argument
  /// otherwise). A device that cannot be opened or written leaves the request not applied,
  /// with the reason in message().
  explicit CpuLatencyRequest(int latency_us, const std::string& device = kCpuLatencyDevice);
  ~CpuLatencyRequest();
  CpuLatencyRequest(CpuLatencyRequest&& other) noexcept;
  CpuLatencyRequest& operator=(CpuLatencyRequest&& other) noexcept;
  CpuLatencyRequest(const CpuLatencyRequest&) = delete;
  CpuLatencyRequest& operator=(const CpuLatencyRequest&) = delete;

  bool applied() const { return fd_ >= 0; }
  const std::string& message() const { return message_; }

 private:
  int fd_ = -1;
  std::string message_;
};

/// The bound in force on the system (the smallest held request, or the kernel's default when
/// none is held), read from `device`; -1 when it cannot be read.
int cpu_latency_in_force_us(const std::string& device = kCpuLatencyDevice);

}  // namespace fuse

// The bounded queue between the DDS callbacks and fuse-record's writer thread: bounded in bytes
// (each sample also costs a fixed overhead, so tiny samples are bounded too). A sample that does
// not fit is refused, and the caller counts it: memory stays bounded, nothing is lost silently.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <vector>

namespace fuse::record {

struct QueuedSample {
  std::size_t topic = 0;  ///< index into the recorded topics
  std::vector<std::uint8_t> data;
  std::chrono::steady_clock::time_point received;  ///< when the reader handed it over
};

class SampleQueue {
 public:
  /// Bookkeeping cost charged per queued sample besides its bytes.
  static constexpr std::size_t kPerSampleOverhead = 64;

  explicit SampleQueue(std::size_t capacity_bytes) : capacity_(capacity_bytes) {}
  /// Copies the sample in; false (nothing queued) when it would exceed the capacity.
  bool push(std::size_t topic, const std::uint8_t* data, std::size_t size);
  /// Waits up to `timeout` for a sample.
  std::optional<QueuedSample> pop(std::chrono::milliseconds timeout);
  std::size_t bytes() const;
  std::size_t peak_bytes() const;
  std::size_t capacity() const { return capacity_; }

 private:
  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<QueuedSample> items_;
  std::size_t bytes_ = 0, peak_ = 0;
};

}  // namespace fuse::record

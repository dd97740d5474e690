#include "sample_queue.hpp"

#include <algorithm>

namespace fuse::record {

bool SampleQueue::push(std::size_t topic, const std::uint8_t* data, std::size_t size) {
  const std::size_t cost = size + kPerSampleOverhead;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (bytes_ + cost > capacity_) return false;
    items_.push_back(QueuedSample{topic, std::vector<std::uint8_t>(data, data + size), std::chrono::steady_clock::now()});
    bytes_ += cost;
    peak_ = std::max(peak_, bytes_);
  }
  cv_.notify_one();
  return true;
}

std::optional<QueuedSample> SampleQueue::pop(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!cv_.wait_for(lock, timeout, [this] { return !items_.empty(); })) return std::nullopt;
  QueuedSample s = std::move(items_.front());
  items_.pop_front();
  bytes_ -= s.data.size() + kPerSampleOverhead;
  return s;
}

std::size_t SampleQueue::bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return bytes_;
}

std::size_t SampleQueue::peak_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return peak_;
}

}  // namespace fuse::record

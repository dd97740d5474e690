#include "fuse/io/prefetch_source.hpp"

#include <stdexcept>

namespace fuse::io {

PrefetchSource::PrefetchSource(std::unique_ptr<SensorSource> inner, std::size_t capacity)
    : inner_(std::move(inner)),
      capacity_(capacity),
      T_imu_lidar_(inner_ ? inner_->T_imu_lidar() : std::nullopt),
      describe_(inner_ ? inner_->describe() : std::string()),
      expected_events_(inner_ ? inner_->expected_events() : std::nullopt) {
  if (!inner_) throw std::invalid_argument("PrefetchSource needs a source");
  if (capacity_ < 1) throw std::invalid_argument("PrefetchSource capacity must be at least 1");
  delivered_ = inner_->stats();
  rejected_ = std::make_shared<const std::map<std::string, std::uint64_t>>(delivered_.rejected);
  delivered_rejected_ = rejected_;
  reader_ = std::thread([this] { read_loop(); });
}

PrefetchSource::~PrefetchSource() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closing_ = true;
  }
  changed_.notify_all();
  // A live inner source may block in next(); recordings and sequence directories do not.
  reader_.join();
}

void PrefetchSource::read_loop() {
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [&] { return closing_ || queue_.size() < capacity_; });
      if (closing_) return;
    }
    SensorEvent ev;
    bool more = false;
    std::exception_ptr error;
    try {
      more = inner_->next(ev);
    } catch (...) {
      error = std::current_exception();
    }
    const SourceStats& now = inner_->stats();
    if (*rejected_ != now.rejected) rejected_ = std::make_shared<const std::map<std::string, std::uint64_t>>(now.rejected);
    Read read{std::move(ev), SourceStats{now.imu_samples, now.scans, now.imu_refused, now.scans_refused, {}}, rejected_};
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (more) queue_.push_back(std::move(read));
      if (!more || error) {
        done_ = true;
        error_ = error;
        final_stats_ = now;
      }
    }
    changed_.notify_all();
    if (!more || error) return;
  }
}

bool PrefetchSource::next(SensorEvent& out) {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [&] { return !queue_.empty() || done_; });
  if (!queue_.empty()) {
    Read& read = queue_.front();
    out = std::move(read.ev);
    std::map<std::string, std::uint64_t> rejected = std::move(delivered_.rejected);
    if (read.rejected != delivered_rejected_) {  // the reader shares one map until it changes
      delivered_rejected_ = read.rejected;
      rejected = *read.rejected;
    }
    delivered_ = read.counts;
    delivered_.rejected = std::move(rejected);
    queue_.pop_front();
    lock.unlock();
    changed_.notify_all();
    return true;
  }
  delivered_ = final_stats_;  // what the source refused after its last event counts too
  if (error_) std::rethrow_exception(error_);
  return false;
}

const SourceStats& PrefetchSource::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  stats_snapshot_ = delivered_;
  return stats_snapshot_;
}

}  // namespace fuse::io

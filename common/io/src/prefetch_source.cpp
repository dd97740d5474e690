#include "fuse/io/prefetch_source.hpp"

#include <stdexcept>

namespace fuse::io {

PrefetchSource::PrefetchSource(std::unique_ptr<SensorSource> inner, std::size_t capacity)
    : inner_(std::move(inner)),
      capacity_(capacity),
      T_imu_lidar_(inner_ ? inner_->T_imu_lidar() : std::nullopt),
      describe_(inner_ ? inner_->describe() : std::string()) {
  if (!inner_) throw std::invalid_argument("PrefetchSource needs a source");
  if (capacity_ < 1) throw std::invalid_argument("PrefetchSource capacity must be at least 1");
  stats_ = inner_->stats();
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
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stats_ = inner_->stats();
      if (more) queue_.push_back(std::move(ev));
      if (!more || error) {
        done_ = true;
        error_ = error;
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
    out = std::move(queue_.front());
    queue_.pop_front();
    lock.unlock();
    changed_.notify_all();
    return true;
  }
  if (error_) std::rethrow_exception(error_);
  return false;
}

const SourceStats& PrefetchSource::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  stats_snapshot_ = stats_;
  return stats_snapshot_;
}

}  // namespace fuse::io

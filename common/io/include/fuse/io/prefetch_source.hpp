// A SensorSource that reads ahead of its consumer on its own thread.
//
// Reading a recording is bursty: an MCAP chunk is decompressed and decoded when its first
// message is asked for, which can take tens of milliseconds, while a real-time replay must
// publish an IMU sample every 5 ms. Reading ahead into a bounded queue takes that cost off the
// scheduling thread. Events come out in the same order and unchanged; an InputError raised by
// the inner source is raised again by next() in its place in the stream (after the events read
// before it). stats() counts what has been delivered, not what has been read ahead: a refusal
// counts once the consumer has reached the point of the stream where it happened (a consumer that
// judges time without data by it sees it in its place). It is a snapshot, safe to call from any
// thread.
#pragma once

#include <condition_variable>
#include <deque>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "fuse/io/sensor_source.hpp"

namespace fuse::io {

class PrefetchSource : public SensorSource {
 public:
  /// Starts reading `inner` at once, keeping at most `capacity` (>= 1) events ahead.
  PrefetchSource(std::unique_ptr<SensorSource> inner, std::size_t capacity);
  ~PrefetchSource() override;
  PrefetchSource(const PrefetchSource&) = delete;
  PrefetchSource& operator=(const PrefetchSource&) = delete;

  bool next(SensorEvent& out) override;
  std::optional<Eigen::Isometry3d> T_imu_lidar() const override { return T_imu_lidar_; }
  const SourceStats& stats() const override;
  std::string describe() const override { return describe_; }
  std::optional<std::uint64_t> expected_events() const override { return expected_events_; }

 private:
  void read_loop();
  /// An event with the inner source's counters just after it was read.
  struct Read {
    SensorEvent ev;
    SourceStats counts;  ///< without `rejected`: that map is shared while it does not change
    std::shared_ptr<const std::map<std::string, std::uint64_t>> rejected;
  };

  std::unique_ptr<SensorSource> inner_;
  const std::size_t capacity_;
  const std::optional<Eigen::Isometry3d> T_imu_lidar_;
  const std::string describe_;
  const std::optional<std::uint64_t> expected_events_;

  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Read> queue_;
  bool done_ = false;      ///< the reader has reached the end (or an error)
  bool closing_ = false;   ///< the destructor asks the reader to stop
  std::exception_ptr error_;
  SourceStats final_stats_;             ///< the inner source's, once it has ended
  std::shared_ptr<const std::map<std::string, std::uint64_t>> rejected_;  ///< reader thread only
  SourceStats delivered_;               ///< as of the last event next() gave out
  std::shared_ptr<const std::map<std::string, std::uint64_t>> delivered_rejected_;  ///< behind delivered_.rejected
  mutable SourceStats stats_snapshot_;  ///< what stats() returns
  std::thread reader_;
};

}  // namespace fuse::io

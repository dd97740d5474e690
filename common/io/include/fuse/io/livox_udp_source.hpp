// Live Livox Mid-360 input (SDK2 protocol, livox_packet.hpp): point cloud packets on one UDP port
// (56301 by default) and IMU packets on another (56401), decoded on a receiver thread; points
// are grouped into scans of a configured period (ScanAssembler). Events wait in a bounded queue
// for next(); what does not fit is counted. Malformed packets are counted by reason and logged
// (rate-limited), never fatal.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>

#include "fuse/io/livox_scan_assembler.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/io/source_validator.hpp"

namespace fuse::io {

struct LivoxUdpConfig {
  std::string address = "0.0.0.0";                  ///< local address to bind (IPv4)
  std::uint16_t point_port = livox::kDefaultPointPort;  ///< 0: any free port (see point_port())
  std::uint16_t imu_port = livox::kDefaultImuPort;      ///< 0: any free port
  double scan_period_s = 0.1;
  std::size_t queue_capacity = 4096;  ///< events (IMU samples and scans) waiting for next()
  /// next() ends the stream after this long without a packet; 0 waits for ever (until stop()).
  double idle_timeout_s = 0.0;
  /// Polled by the receiver thread (every 50 ms): true ends the stream, as stop() does (e.g. a
  /// service's SIGTERM flag, so a blocked next() returns).
  std::function<bool()> should_stop;
};

/// Counter keys besides livox::reject::*.
namespace livox_reason {
inline constexpr const char* kQueueOverflow = "livox_queue_overflow";
inline constexpr const char* kLatePoints = "livox_late_points";
inline constexpr const char* kEmptyReturns = "livox_empty_returns";
inline constexpr const char* kImuOnPointPort = "livox_imu_on_point_port";
}  // namespace livox_reason

class LivoxUdpSource : public SensorSource {
 public:
  /// Binds both sockets and starts receiving; throws InputError naming the port that failed.
  explicit LivoxUdpSource(const LivoxUdpConfig& config);
  ~LivoxUdpSource() override;
  LivoxUdpSource(const LivoxUdpSource&) = delete;
  LivoxUdpSource& operator=(const LivoxUdpSource&) = delete;

  bool next(SensorEvent& out) override;
  std::optional<Eigen::Isometry3d> T_imu_lidar() const override { return std::nullopt; }
  const SourceStats& stats() const override { return stats_; }
  std::string describe() const override;

  /// Ends the stream: next() returns false once the queue is drained.
  void stop();
  std::uint16_t point_port() const { return point_port_; }
  std::uint16_t imu_port() const { return imu_port_; }
  /// Packets received and packets refused (all reasons), so far.
  std::uint64_t packets() const { return packets_; }
  std::uint64_t malformed() const { return malformed_; }

 private:
  void receive_loop();
  void handle(const std::uint8_t* data, std::size_t size, bool point_port);
  void push(SensorEvent&& ev);  ///< with mutex_ held
  void count(const std::string& reason, const std::string& detail, std::uint64_t n = 1);  ///< with mutex_ held

  LivoxUdpConfig config_;
  int point_fd_ = -1, imu_fd_ = -1;
  std::uint16_t point_port_ = 0, imu_port_ = 0;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> packets_{0}, malformed_{0};

  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<SensorEvent> queue_;
  std::deque<SensorEvent> passed_;  ///< checked (SourceValidator), read by next() only
  livox::ScanAssembler assembler_;
  std::uint64_t late_reported_ = 0, empty_reported_ = 0;
  std::uint64_t imu_sequence_ = 0;
  SourceValidator validator_;
  SourceStats stats_;  ///< copy of the validator's, refreshed by next()
  bool receiver_done_ = false;
  std::thread thread_;
};

}  // namespace fuse::io

// Live Ouster input: the sensor's lidar and IMU UDP packets (ports from the metadata, or set
// here; one socket when both are the same port) read on a receiver thread and turned into
// scans and IMU samples by an ouster::Stream (ouster_stream.hpp) with the sensor's metadata.
// Events are released in time order once 50 ms of newer sensor time has arrived, or at once
// when the input has been quiet for 50 ms; they wait in a bounded queue for next(); what does
// not fit is counted. Malformed or
// foreign packets are counted by reason and logged (rate-limited), never fatal. The stream
// never ends on its own: stop(), the should_stop predicate or the idle timeout end it.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "fuse/io/ouster_stream.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/io/source_validator.hpp"

namespace fuse::io {

struct OusterUdpConfig {
  std::string metadata;                      ///< the sensor's metadata JSON
  std::string address = "0.0.0.0";           ///< local IPv4 address to bind
  std::optional<std::uint16_t> lidar_port;   ///< instead of the metadata's; 0: any free port
  std::optional<std::uint16_t> imu_port;
  std::size_t queue_capacity = 4096;         ///< events waiting for next()
  double idle_timeout_s = 0.0;               ///< end after this long without a packet; 0: never
  /// Polled by the receiver thread (every 50 ms): true ends the stream, as stop() does.
  std::function<bool()> should_stop;
};

class OusterUdpSource : public SensorSource {
 public:
  /// Reads the metadata, binds the port(s) and starts receiving; throws InputError.
  explicit OusterUdpSource(const OusterUdpConfig& config);
  ~OusterUdpSource() override;
  OusterUdpSource(const OusterUdpSource&) = delete;
  OusterUdpSource& operator=(const OusterUdpSource&) = delete;

  bool next(SensorEvent& out) override;
  std::optional<Eigen::Isometry3d> T_imu_lidar() const override { return meta_.T_imu_sensor(); }
  const SourceStats& stats() const override { return stats_; }
  std::string describe() const override;

  void stop();
  std::uint16_t lidar_port() const { return lidar_port_; }
  std::uint16_t imu_port() const { return imu_port_; }
  std::uint64_t packets() const { return packets_; }

 private:
  void receive_loop();

  OusterUdpConfig config_;
  ouster::Metadata meta_;
  int lidar_fd_ = -1, imu_fd_ = -1;
  std::uint16_t lidar_port_ = 0, imu_port_ = 0;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> packets_{0};

  std::mutex mutex_;
  std::condition_variable cv_;
  SourceValidator validator_;
  std::unique_ptr<ouster::Stream> stream_;
  std::deque<SensorEvent> queue_;
  std::deque<SensorEvent> passed_;  ///< checked (SourceValidator), read by next() only
  SourceStats stats_;
  bool receiver_done_ = false;
  std::thread thread_;
};

}  // namespace fuse::io

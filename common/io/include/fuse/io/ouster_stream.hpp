// One Ouster sensor's UDP stream → time-ordered sensor events; shared by the pcap replay and
// the live UDP source. Datagrams are routed by destination port (the metadata's lidar / IMU
// ports, which may be the same): lidar packets are decoded against the metadata
// (ouster_packet.hpp) and assembled into scans (ouster_scan_assembler.hpp), IMU packets become
// IMU samples.
//
// Several sensors may send to the same ports (ouster-sdk's same_ports captures). A lidar packet
// is this sensor's when it fits the metadata: its size for the profile and, for profile
// packets, the initialization id and serial number in its header. Its sender's IPv4 address is
// then recorded as this sensor's; an address whose lidar packets do not fit is another
// sensor's. IMU packets (48 bytes, no identification) are taken from this sensor's addresses,
// refused from another sensor's, and taken from an address not seen yet only while no other
// sensor has been seen (learn() lets a replay identify every sender before it starts).
//
// Refusals are counted by reason (ouster::reject::*, plus the keys below) and logged.
#pragma once

#include <cstdint>
#include <deque>
#include <set>
#include <string>
#include <vector>

#include "fuse/io/ouster_metadata.hpp"
#include "fuse/io/ouster_packet.hpp"
#include "fuse/io/ouster_scan_assembler.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/io/source_validator.hpp"

namespace fuse::io::ouster {

namespace reject {
inline constexpr const char* kIncompleteFrame = "ouster_incomplete_frame";       ///< frame dropped
inline constexpr const char* kOtherSensorImu = "ouster_other_sensor_imu";        ///< IMU of another sender
inline constexpr const char* kEmptyReturns = "ouster_empty_returns";             ///< range 0: no point
inline constexpr const char* kEventOrder = "ouster_event_out_of_order";          ///< later than the window
}  // namespace reject

class Stream {
 public:
  /// `reorder_window_s`: events are held this long (sensor time) to be released in time order.
  Stream(Metadata meta, SourceValidator& validator, double reorder_window_s = 0.05);

  /// Identification only (no events): records which sender addresses are this sensor's.
  void learn(const std::uint8_t* data, std::size_t size, std::uint32_t src_ip, std::uint16_t dst_port);
  /// Handles one datagram; events that are due are appended to `out` in time order.
  void handle(const std::uint8_t* data, std::size_t size, std::uint32_t src_ip, std::uint16_t dst_port,
              std::deque<SensorEvent>& out);
  /// End of input: the frame in progress is reported and every held event is released.
  void finish(std::deque<SensorEvent>& out);
  /// Releases every held event now (a live input that went quiet: nothing older will come).
  void release_held(std::deque<SensorEvent>& out) { release(1e300, out); }

  const Metadata& metadata() const { return meta_; }
  std::uint64_t lidar_packets() const { return lidar_packets_; }  ///< decoded as this sensor's
  std::uint64_t imu_packets() const { return imu_packets_; }
  std::uint64_t scans() const { return scans_; }
  std::uint64_t datagrams_on_ports() const { return on_ports_; }
  std::uint64_t dropped_frames() const { return dropped_frames_; }
  /// The first refusal of a lidar packet (for an end-of-input message), empty when none.
  const std::string& first_lidar_rejection() const { return first_lidar_rejection_; }
  const std::string& last_dropped_frame() const { return last_dropped_; }

 private:
  void hold(SensorEvent&& ev);
  void release(double horizon, std::deque<SensorEvent>& out);
  void report(const std::vector<ScanAssembler::Dropped>& dropped);

  Metadata meta_;
  SourceValidator& validator_;
  double reorder_window_s_;
  ScanAssembler assembler_;
  std::set<std::uint32_t> ours_, others_;
  std::vector<SensorEvent> held_;  ///< min-heap by arrival time
  double newest_ = -1e300;
  double released_ = -1e300;
  std::uint64_t lidar_packets_ = 0, imu_packets_ = 0, scans_ = 0, on_ports_ = 0, dropped_frames_ = 0;
  std::uint64_t empty_reported_ = 0, imu_sequence_ = 0;
  std::string first_lidar_rejection_, last_dropped_;
  LidarPacket packet_;
};

}  // namespace fuse::io::ouster

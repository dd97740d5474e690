// Replay of an Ouster capture: a pcap file (pcap_reader.hpp) of one or more sensors' UDP
// packets and the metadata JSON of the sensor to read (ouster_metadata.hpp). Datagrams on the
// metadata's lidar / IMU ports (overridable) go through an ouster::Stream, which assembles scans
// and IMU samples, tells this sensor's packets from another sensor's on the same ports, and
// releases events in time order. The sender addresses are identified in a first pass over the
// file, so IMU packets that come before the first lidar packet are attributed too.
//
// Scans are in the sensor frame (T_imu_lidar() is inv(imu_to_sensor_transform)). The end of a
// capture that produced no full frame raises InputError saying why (no packets, none on the
// ports, packets that do not fit the metadata, or only incomplete frames).
#pragma once

#include <deque>
#include <memory>
#include <optional>
#include <string>

#include "fuse/io/ouster_stream.hpp"
#include "fuse/io/pcap_reader.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/io/source_validator.hpp"

namespace fuse::io {

struct OusterPcapConfig {
  std::string pcap;
  std::string metadata;
  std::optional<std::uint16_t> lidar_port;  ///< instead of the metadata's
  std::optional<std::uint16_t> imu_port;
};

class OusterPcapSource : public SensorSource {
 public:
  /// Reads the metadata and the pcap's file header; throws InputError.
  explicit OusterPcapSource(const OusterPcapConfig& config);

  bool next(SensorEvent& out) override;
  std::optional<Eigen::Isometry3d> T_imu_lidar() const override { return meta_.T_imu_sensor(); }
  const SourceStats& stats() const override { return validator_.stats(); }
  std::string describe() const override;

  const ouster::Metadata& metadata() const { return meta_; }
  const ouster::Stream& stream() const { return *stream_; }
  const pcap::PcapReader& reader() const { return *reader_; }

 private:
  OusterPcapConfig config_;
  ouster::Metadata meta_;
  SourceValidator validator_;
  std::unique_ptr<ouster::Stream> stream_;
  std::unique_ptr<pcap::PcapReader> reader_;
  std::deque<SensorEvent> ready_;   ///< assembled, not yet checked
  std::deque<SensorEvent> passed_;  ///< checked (SourceValidator)
  bool finished_ = false;
  std::string error_;  ///< raised once the events are delivered: no full frame
  std::uint64_t datagrams_ = 0;
};

/// Metadata of `config`, with its ports overridden as configured (shared by the sources).
ouster::Metadata load_ouster_metadata(const std::string& path, std::optional<std::uint16_t> lidar_port,
                                      std::optional<std::uint16_t> imu_port);

}  // namespace fuse::io

// Ouster lidar packets → scans. Columns are grouped by frame id; a frame is full once every
// column of the metadata's column window has arrived with a valid status, and is emitted then
// (without waiting for the next frame). A frame that ends (a packet of another frame id
// arrives, or the input ends) before it is full is dropped and reported, never emitted.
//
// Points (Ouster Sensor Docs, "Lidar Range to XYZ"): for a pixel of beam i in the column with
// measurement id m, of range r (mm),
//   θ_e = 2π (1 − m / columns_per_frame)            encoder angle
//   θ_a = −2π beam_azimuth_angles[i] / 360           beam azimuth offset
//   φ   =  2π beam_altitude_angles[i] / 360          beam altitude
//   n   = |(beam_offset_x, beam_offset_z)|           lidar_origin_to_beam_origin_mm in the flat layout
//   x = (r − n) cos(θ_e + θ_a) cos φ + beam_offset_x cos θ_e
//   y = (r − n) sin(θ_e + θ_a) cos φ + beam_offset_x sin θ_e
//   z = (r − n) sin φ + beam_offset_z
// in the Ouster lidar frame, then lidar_to_sensor_transform takes it to the sensor frame;
// scans are in the sensor frame, in metres (the source's T_imu_lidar is then T_imu_sensor).
// Pixels of range 0 are empty returns and give no point. Each point's time is its column's
// timestamp; the scan spans the first to the last column time of the window.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fuse/core/types.hpp"
#include "fuse/io/ouster_metadata.hpp"
#include "fuse/io/ouster_packet.hpp"

namespace fuse::io::ouster {

class ScanAssembler {
 public:
  explicit ScanAssembler(const Metadata& meta);

  /// A frame that ended before it was full.
  struct Dropped {
    std::uint16_t frame_id = 0;
    int columns = 0;   ///< valid window columns received
    int expected = 0;  ///< window columns
  };

  /// Adds a decoded packet; a frame it completes is appended to `scans`, a frame it ends
  /// unfinished to `dropped`.
  void add(const LidarPacket& packet, std::vector<LidarScan>& scans, std::vector<Dropped>& dropped);
  /// End of input: the frame in progress, if any, is dropped (it is not full).
  void flush(std::vector<Dropped>& dropped);
  /// Empty returns (range 0) in the emitted scans so far.
  std::uint64_t empty_returns() const { return empty_returns_; }

  /// Sensor-frame point (metres) of one pixel; exposed for tests.
  Eigen::Vector3d point(int measurement_id, int beam, std::uint32_t range_mm) const;

 private:
  void start(std::uint16_t frame_id);

  Metadata meta_;
  std::vector<double> cos_alt_, sin_alt_, az_;
  std::vector<double> cos_enc_, sin_enc_;
  double n_ = 0.0;
  Eigen::Matrix3d R_;
  Eigen::Vector3d t_mm_;

  bool active_ = false, emitted_ = false;
  std::uint16_t frame_id_ = 0;
  int columns_ = 0;
  std::vector<char> seen_;
  std::uint64_t t_min_ns_ = 0, t_max_ns_ = 0;
  struct Raw {
    float x, y, z, intensity;
    std::uint64_t t_ns;
    std::uint16_t ring;
  };
  std::vector<Raw> raw_;
  std::uint64_t empty_in_frame_ = 0, empty_returns_ = 0;
  std::uint64_t sequence_ = 0;
};

}  // namespace fuse::io::ouster

// SensorSource over an MCAP recording written by RecordingWriter (or any MCAP file with the
// same channels): `imu` and `lidar/scan` CDR samples in log-time order; other channels ignored.
// A read error (e.g. the end of a truncated file read in salvage mode) is raised by next() only
// after every event read before it has been delivered.
#pragma once

#include <deque>
#include <optional>
#include <set>
#include <string>

#include "fuse/io/mcap_reader.hpp"
#include "fuse/io/source_validator.hpp"

namespace fuse::io {

class McapSource : public SensorSource {
 public:
  explicit McapSource(const std::string& path, const TimeGateConfig& clock = {});
  bool next(SensorEvent& out) override;
  std::optional<Eigen::Isometry3d> T_imu_lidar() const override { return T_imu_lidar_; }
  const SourceStats& stats() const override { return validator_.stats(); }
  std::string describe() const override;
  /// Restarts the reader at log time t: chunks that end before t are not read.
  bool seek(double t) override;
  std::optional<std::uint64_t> expected_events() const override;

 private:
  /// Reads every message sharing the next log time, decoded, IMU before scans.
  bool fill();
  /// reader_.next(), keeping an InputError in read_error_ (then false) instead of throwing.
  bool read(McapMessage& m);
  std::optional<SensorEvent> decode(const McapMessage& m);

  std::string path_;
  McapReader reader_;
  SourceValidator validator_;
  std::optional<Eigen::Isometry3d> T_imu_lidar_;
  std::optional<McapMessage> lookahead_;
  std::optional<InputError> read_error_;
  std::deque<SensorEvent> ready_;   ///< decoded, not yet checked
  std::deque<SensorEvent> passed_;  ///< checked (SourceValidator), in stream order
  std::set<std::uint16_t> unknown_channels_;
};

/// Parses the kCalibrationMetadata record (keys tx ty tz qx qy qz qw); bad values -> InputError.
Eigen::Isometry3d parse_calibration_metadata(const mcap::StringMap& values, const std::string& where);

}  // namespace fuse::io

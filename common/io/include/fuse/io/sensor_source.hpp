// Time-ordered stream of sensor data from a file (MCAP recording or sequence directory).
// Inputs from outside are checked here: bad records raise InputError with a message naming
// what was wrong, or are skipped and counted in SourceStats (never silently dropped).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "fuse/core/time_gate.hpp"
#include "fuse/core/types.hpp"

namespace fuse::io {

/// A file or record that cannot be read as what it claims to be.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One event in arrival order: an IMU sample arrives at its time, a scan at its end time.
struct SensorEvent {
  enum class Kind { kImu, kLidar };
  Kind kind = Kind::kImu;
  ImuSample imu;   ///< valid when kind == kImu
  LidarScan scan;  ///< valid when kind == kLidar
  double arrival_time() const { return kind == Kind::kImu ? imu.t : scan.t_end; }
};

/// Counters of what a source refused or repaired, by reason (e.g. "nan_imu_sample").
struct SourceStats {
  std::uint64_t imu_samples = 0;
  std::uint64_t scans = 0;
  std::uint64_t imu_refused = 0, scans_refused = 0;  ///< samples dropped by the checks
  std::map<std::string, std::uint64_t> rejected;  ///< reason -> count
};

class SensorSource {
 public:
  virtual ~SensorSource() = default;
  /// Next event in arrival order; false at the end. Throws InputError on an unreadable file.
  virtual bool next(SensorEvent& out) = 0;
  /// LiDAR pose in the IMU frame (p_imu = R * p_lidar + t), when the input carries one.
  virtual std::optional<Eigen::Isometry3d> T_imu_lidar() const = 0;
  virtual const SourceStats& stats() const = 0;
  virtual std::string describe() const = 0;
  /// Positions the source so that next() continues with the first event arriving at or after t
  /// (seconds), without reading what lies before when the format allows (an MCAP chunk index).
  /// false when the source cannot seek: then nothing changed. Forward only.
  virtual bool seek(double t) {
    (void)t;
    return false;
  }
  /// How many IMU samples and scans the input holds, when it says so without reading it all (an
  /// MCAP file's statistics): for a progress percentage. Unset when unknown.
  virtual std::optional<std::uint64_t> expected_events() const { return std::nullopt; }
};

/// Opens an MCAP recording (a file) or a sequence directory (a folder), by what the path is;
/// `clock` configures the time checks of its streams (estimator.clock).
std::unique_ptr<SensorSource> open_sensor_source(const std::string& path, const TimeGateConfig& clock = {});

}  // namespace fuse::io

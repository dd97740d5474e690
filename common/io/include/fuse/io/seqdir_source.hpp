// SensorSource over a sequence directory (format in seqdir.hpp). The CSV files are parsed and
// checked when opening; raw scans are read one at a time as they are reached.
#pragma once

#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "fuse/io/source_validator.hpp"

namespace fuse::io {

/// Above this a timestamp in imu.csv is nanoseconds, below it seconds (1e10 s is year 2286,
/// 1e10 ns is 10 s: the two ranges do not overlap for real logs).
inline constexpr double kNanosecondThreshold = 1e10;
/// Bytes per raw point: float32 x, y, z, intensity, t_rel, ring.
inline constexpr std::size_t kRawPointBytes = 24;

class SeqdirSource : public SensorSource {
 public:
  explicit SeqdirSource(const std::string& dir, const TimeGateConfig& clock = {});
  bool next(SensorEvent& out) override;
  std::optional<Eigen::Isometry3d> T_imu_lidar() const override { return T_imu_lidar_; }
  const SourceStats& stats() const override { return validator_.stats(); }
  std::string describe() const override;

 private:
  struct ScanEntry {
    std::uint64_t index = 0;
    double t_start = 0.0, t_end = 0.0;
    std::string raw_path;
    std::size_t line = 0;  ///< in scans.csv, for messages
  };
  void read_scans_csv();
  void read_imu_csv();
  void read_calib();
  LidarScan load_scan(const ScanEntry& entry) const;
  /// Reads each stream through its time check until it has a sample to offer (or is exhausted).
  void fill_streams();

  std::string dir_;
  std::vector<ScanEntry> scans_;
  std::vector<ImuSample> imu_;
  std::size_t next_scan_ = 0, next_imu_ = 0;
  /// An event that passed the checks, with the clock steps its stream made before it.
  struct Passed {
    double t;       ///< stamp (IMU: t, scan: t_end)
    double offset;  ///< s: the sum of its stream's clock steps (SourceValidator::clock_offset)
    SensorEvent event;
  };
  /// The time a passed event is merged on: its stream's continuous time, t − offset (a stream that
  /// stepped merges where it arrived). Scans whose clock stepped as the IMU's did use the IMU's
  /// offset: the same step, measured to an IMU period instead of a scan period.
  double merge_time(const Passed& p) const;
  std::deque<Passed> imu_passed_, scans_passed_;  ///< checked, in file order
  std::optional<Eigen::Isometry3d> T_imu_lidar_;
  SourceValidator validator_;
  double max_gap_s_;  ///< estimator.clock.max_gap_s
};

/// Reads calib.yaml (T_imu_lidar: {translation: [x,y,z], rotation_xyzw: [qx,qy,qz,qw]}).
Eigen::Isometry3d read_calib_yaml(const std::string& file);

}  // namespace fuse::io

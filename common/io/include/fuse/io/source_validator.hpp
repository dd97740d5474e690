// Checks applied to every sample entering the system from a sensor source (DESIGN: validate at
// the boundary): values (NaN), scan times, and each stream's time through a TimeGate (duplicates,
// out-of-order samples, isolated jumps, clock steps: fuse/core/time_gate.hpp). Rejections are
// counted by reason in SourceStats and logged, rate-limited.
#pragma once

#include <deque>
#include <map>
#include <string>
#include <vector>

#include "fuse/core/counters.hpp"
#include "fuse/core/time_gate.hpp"
#include "fuse/core/types.hpp"
#include "fuse/io/sensor_source.hpp"

namespace fuse::io {

/// Rejection reasons (keys of SourceStats::rejected).
namespace reason {
inline constexpr const char* kNanImu = "nan_imu_sample";            ///< dropped
inline constexpr const char* kImuDuplicate = "imu_duplicate";       ///< dropped (same stamp as the last)
inline constexpr const char* kImuOutOfOrder = "imu_out_of_order";   ///< dropped (behind by at most clock.max_gap_s)
inline constexpr const char* kImuTimeOutlier = "imu_time_outlier";  ///< dropped (a jump and back, not confirmed)
inline constexpr const char* kImuClockStep = "imu_clock_step";      ///< passed on: the stream's new time base
inline constexpr const char* kNanScanTime = "nan_scan_time";        ///< dropped
inline constexpr const char* kScanEndBeforeStart = "scan_end_before_start";  ///< dropped
inline constexpr const char* kScanDuplicate = "scan_duplicate";              ///< dropped
inline constexpr const char* kScanOutOfOrder = "scan_out_of_order";          ///< dropped
inline constexpr const char* kScanTimeOutlier = "scan_time_outlier";         ///< dropped
inline constexpr const char* kScanClockStep = "scan_clock_step";             ///< passed on
inline constexpr const char* kNanPoints = "nan_points";             ///< points removed (count of points)
inline constexpr const char* kEmptyScan = "empty_scan";             ///< passed on, counted
inline constexpr const char* kUnknownChannel = "unknown_channel";   ///< ignored, counted once per channel
}  // namespace reason

class SourceValidator {
 public:
  /// `interleaved`: the events of both streams are checked in their order of arrival, so the IMU
  /// stream's time at a scan decides the scan's jump at once; false for streams read from
  /// separate files and merged after the check (a scan's jump then waits for the next scans).
  explicit SourceValidator(std::string source, const TimeGateConfig& clock = {}, bool interleaved = true);

  /// Checks one event and appends the events that pass to `passed`, in stream order: none while a
  /// forward jump of the stream waits for the samples after it, the held ones with the sample
  /// that confirms it. Scans lose their points with non-finite coordinates or time offset.
  void check(SensorEvent event, std::deque<SensorEvent>& passed);
  /// The end of the input: samples still held for a confirmation that cannot come are outliers.
  void finish();
  /// The source jumped on purpose (SensorSource::seek): forgets each stream's time and what it
  /// held, so the first samples after the jump start the streams afresh instead of looking like
  /// a clock step.
  void restart();
  /// s: the sum of the clock steps that the stream of `kind` made so far; stamp − offset runs on
  /// continuously across them (a sequence directory merges its two files on it).
  double clock_offset(SensorEvent::Kind kind) const {
    return kind == SensorEvent::Kind::kImu ? imu_.offset : scans_.offset;
  }
  /// Counts `n` occurrences of `reason` and logs `detail` (rate-limited per reason).
  void count(const std::string& reason, const std::string& detail, std::uint64_t n = 1);

  const SourceStats& stats() const { return stats_; }

 private:
  /// One stream's time check: the gate and the events it holds (decided in push order).
  struct Stream {
    explicit Stream(const TimeGateConfig& clock) : gate(clock) {}
    TimeGate gate;
    double offset = 0.0;  ///< s: sum of the clock steps passed on
    std::deque<SensorEvent> held;
    std::vector<TimeGate::Decision> decisions;
  };
  bool values_ok(const ImuSample& imu);
  bool values_ok(LidarScan& scan);
  /// Pushes an event through its stream's gate; appends the events that pass to `passed`.
  void gate(Stream& stream, SensorEvent event, double t, std::optional<double> reference, std::deque<SensorEvent>& passed);

  std::string source_;
  SourceStats stats_;
  std::map<std::string, LogRateLimit> limits_;  ///< per reason
  Stream imu_, scans_;
  bool interleaved_;
};

}  // namespace fuse::io

// Checks applied to every sample entering the system from a file (DESIGN: validate at the
// boundary). Rejections are counted by reason in SourceStats and logged, rate-limited.
#pragma once

#include <limits>
#include <string>

#include "fuse/core/types.hpp"
#include "fuse/io/sensor_source.hpp"

namespace fuse::io {

/// Rejection reasons (keys of SourceStats::rejected).
namespace reason {
inline constexpr const char* kNanImu = "nan_imu_sample";            ///< dropped
inline constexpr const char* kImuTimeNotIncreasing = "imu_time_not_increasing";  ///< dropped
inline constexpr const char* kNanScanTime = "nan_scan_time";        ///< dropped
inline constexpr const char* kScanEndBeforeStart = "scan_end_before_start";  ///< dropped
inline constexpr const char* kScanTimeBackwards = "scan_time_backwards";     ///< dropped
inline constexpr const char* kNanPoints = "nan_points";             ///< points removed (count of points)
inline constexpr const char* kEmptyScan = "empty_scan";             ///< passed on, counted
inline constexpr const char* kUnknownChannel = "unknown_channel";   ///< ignored, counted once per channel
}  // namespace reason

class SourceValidator {
 public:
  explicit SourceValidator(std::string source) : source_(std::move(source)) {}

  /// False: drop the sample (counted). True: pass it on.
  bool accept(const ImuSample& imu);
  /// Removes points with non-finite coordinates or time offset; false: drop the scan.
  bool accept(LidarScan& scan);
  /// Counts `n` occurrences of `reason` and logs `detail` (rate-limited per reason).
  void count(const std::string& reason, const std::string& detail, std::uint64_t n = 1);

  const SourceStats& stats() const { return stats_; }

 private:
  std::string source_;
  SourceStats stats_;
  std::map<std::string, std::uint64_t> events_;  ///< occurrences per reason (for rate limiting)
  double last_imu_t_ = -std::numeric_limits<double>::infinity();
  double last_scan_end_ = -std::numeric_limits<double>::infinity();
};

}  // namespace fuse::io

#include "fuse/io/source_validator.hpp"

#include <algorithm>
#include <cmath>

#include "fuse/core/logging.hpp"

namespace fuse::io {
namespace {

/// Rate limit: the first warnings of each reason are all logged, then one in kWarnEvery.
constexpr std::uint64_t kFirstWarnings = 5;
constexpr std::uint64_t kWarnEvery = 1000;

bool finite(const LidarPoint& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) && std::isfinite(p.t_rel);
}

std::string fmt_time(double t) { return fmt::format("{:.9f}", t); }

}  // namespace

void SourceValidator::count(const std::string& why, const std::string& detail, std::uint64_t n) {
  stats_.rejected[why] += n;
  const std::uint64_t k = ++events_[why];
  if (k <= kFirstWarnings || k % kWarnEvery == 0) {
    logger("io")->warn("{}: {}: {} ({} so far{})", source_, why, detail, k,
                       k == kFirstWarnings ? "; further ones logged every " + std::to_string(kWarnEvery) : "");
  }
}

bool SourceValidator::accept(const ImuSample& imu) {
  if (!std::isfinite(imu.t) || !imu.gyro.allFinite() || !imu.accel.allFinite()) {
    count(reason::kNanImu, "IMU sample " + std::to_string(imu.sequence) + " at t=" + fmt_time(imu.t) +
                               " has a NaN/inf value, dropped");
    return false;
  }
  if (imu.t <= last_imu_t_) {
    count(reason::kImuTimeNotIncreasing, "IMU sample " + std::to_string(imu.sequence) + " at t=" + fmt_time(imu.t) +
                                             " not after the previous one at " + fmt_time(last_imu_t_) + ", dropped");
    return false;
  }
  last_imu_t_ = imu.t;
  ++stats_.imu_samples;
  return true;
}

bool SourceValidator::accept(LidarScan& scan) {
  const std::string name = "scan " + std::to_string(scan.sequence);
  if (!std::isfinite(scan.t_start) || !std::isfinite(scan.t_end)) {
    count(reason::kNanScanTime, name + " has a NaN/inf start or end time, dropped");
    return false;
  }
  if (scan.t_end < scan.t_start) {
    count(reason::kScanEndBeforeStart, name + " ends (" + fmt_time(scan.t_end) + ") before it starts (" +
                                           fmt_time(scan.t_start) + "), dropped");
    return false;
  }
  if (scan.t_end <= last_scan_end_) {
    count(reason::kScanTimeBackwards, name + " ends at " + fmt_time(scan.t_end) + ", not after the previous scan's end " +
                                          fmt_time(last_scan_end_) + ", dropped");
    return false;
  }
  last_scan_end_ = scan.t_end;
  const auto bad = std::remove_if(scan.points.begin(), scan.points.end(), [](const LidarPoint& p) { return !finite(p); });
  const auto removed = static_cast<std::uint64_t>(scan.points.end() - bad);
  if (removed > 0) {
    scan.points.erase(bad, scan.points.end());
    count(reason::kNanPoints, name + ": removed " + std::to_string(removed) + " points with NaN/inf values", removed);
  }
  if (scan.points.empty()) count(reason::kEmptyScan, name + " has no points (passed on)");
  ++stats_.scans;
  return true;
}

}  // namespace fuse::io

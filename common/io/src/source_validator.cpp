#include "fuse/io/source_validator.hpp"

#include <algorithm>
#include <cmath>

#include "fuse/core/logging.hpp"

namespace fuse::io {
namespace {

bool finite(const LidarPoint& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) && std::isfinite(p.t_rel);
}

std::string fmt_time(double t) { return fmt::format("{:.9f}", t); }

std::string describe(const SensorEvent& e) {
  return e.kind == SensorEvent::Kind::kImu ? "IMU sample " + std::to_string(e.imu.sequence)
                                           : "scan " + std::to_string(e.scan.sequence);
}

}  // namespace

SourceValidator::SourceValidator(std::string source, const TimeGateConfig& clock, bool interleaved)
    : source_(std::move(source)), imu_(clock), scans_(clock), interleaved_(interleaved) {}

void SourceValidator::count(const std::string& why, const std::string& detail, std::uint64_t n) {
  stats_.rejected[why] += n;
  std::uint64_t suppressed = 0;
  if (!limits_[why].allow(suppressed)) return;
  logger("io")->warn("{}: {}: {} ({} so far{})", source_, why, detail, stats_.rejected[why],
                     suppressed > 0 ? fmt::format("; {} more since the last message", suppressed) : std::string());
}

bool SourceValidator::values_ok(const ImuSample& imu) {
  if (!std::isfinite(imu.t) || !imu.gyro.allFinite() || !imu.accel.allFinite()) {
    ++stats_.imu_refused;
    count(reason::kNanImu, "IMU sample " + std::to_string(imu.sequence) + " at t=" + fmt_time(imu.t) +
                               " has a NaN/inf value, dropped");
    return false;
  }
  return true;
}

bool SourceValidator::values_ok(LidarScan& scan) {
  const std::string name = "scan " + std::to_string(scan.sequence);
  if (!std::isfinite(scan.t_start) || !std::isfinite(scan.t_end)) {
    ++stats_.scans_refused;
    count(reason::kNanScanTime, name + " has a NaN/inf start or end time, dropped");
    return false;
  }
  if (scan.t_end < scan.t_start) {
    ++stats_.scans_refused;
    count(reason::kScanEndBeforeStart, name + " ends (" + fmt_time(scan.t_end) + ") before it starts (" +
                                           fmt_time(scan.t_start) + "), dropped");
    return false;
  }
  return true;
}

void SourceValidator::check(SensorEvent event, std::deque<SensorEvent>& passed) {
  if (event.kind == SensorEvent::Kind::kImu) {
    if (!values_ok(event.imu)) return;
    const double t = event.imu.t;
    gate(imu_, std::move(event), t, std::nullopt, passed);
    return;
  }
  if (!values_ok(event.scan)) return;
  const double t = event.scan.t_end;
  // The IMU stream's time decides a scan's jump (both clocks stepped, or the scan's stamp is wrong).
  const std::optional<double> reference =
      interleaved_ && imu_.gate.started() ? std::optional<double>(imu_.gate.time()) : std::nullopt;
  gate(scans_, std::move(event), t, reference, passed);
}

void SourceValidator::gate(Stream& stream, SensorEvent event, double t, std::optional<double> reference,
                           std::deque<SensorEvent>& passed) {
  stream.held.push_back(std::move(event));
  stream.gate.push(t, stream.decisions, reference);
  for (const TimeGate::Decision& d : stream.decisions) {
    SensorEvent e = std::move(stream.held.front());
    stream.held.pop_front();
    const bool imu = e.kind == SensorEvent::Kind::kImu;
    const std::string what = describe(e) + " at t=" + fmt_time(d.t);
    const bool dropped = d.verdict == TimeGate::Verdict::kDuplicate || d.verdict == TimeGate::Verdict::kOutOfOrder ||
                         d.verdict == TimeGate::Verdict::kOutlier;
    if (dropped) ++(imu ? stats_.imu_refused : stats_.scans_refused);
    switch (d.verdict) {
      case TimeGate::Verdict::kAccept:
        break;
      case TimeGate::Verdict::kClockStep:
        stream.offset += d.step;
        count(imu ? reason::kImuClockStep : reason::kScanClockStep,
              fmt::format("clock step of {:+.3f} s at {} (beyond estimator.clock.max_gap_s, confirmed): passed on as "
                          "the stream's new time",
                          d.step, what));
        break;
      case TimeGate::Verdict::kDuplicate:
        count(imu ? reason::kImuDuplicate : reason::kScanDuplicate, what + " repeats the previous stamp, dropped");
        continue;
      case TimeGate::Verdict::kOutOfOrder:
        count(imu ? reason::kImuOutOfOrder : reason::kScanOutOfOrder,
              fmt::format("{} is {:.6f} s behind the stream, dropped", what, -d.step));
        continue;
      case TimeGate::Verdict::kOutlier:
        count(imu ? reason::kImuTimeOutlier : reason::kScanTimeOutlier,
              fmt::format("{} jumps {:+.3f} s away from the stream and not the samples after it, dropped", what, d.step));
        continue;
    }
    if (imu) {
      ++stats_.imu_samples;
    } else {
      LidarScan& scan = e.scan;
      const auto bad = std::remove_if(scan.points.begin(), scan.points.end(), [](const LidarPoint& p) { return !finite(p); });
      const auto removed = static_cast<std::uint64_t>(scan.points.end() - bad);
      if (removed > 0) {
        scan.points.erase(bad, scan.points.end());
        count(reason::kNanPoints, describe(e) + ": removed " + std::to_string(removed) + " points with NaN/inf values",
              removed);
      }
      if (scan.points.empty()) count(reason::kEmptyScan, describe(e) + " has no points (passed on)");
      ++stats_.scans;
    }
    passed.push_back(std::move(e));
  }
}

void SourceValidator::restart() {
  for (Stream* s : {&imu_, &scans_}) {
    s->gate = TimeGate(s->gate.config());
    s->held.clear();
    s->decisions.clear();
  }
}

void SourceValidator::finish() {
  for (Stream* s : {&imu_, &scans_}) {
    for (const SensorEvent& e : s->held) {
      const bool imu = e.kind == SensorEvent::Kind::kImu;
      ++(imu ? stats_.imu_refused : stats_.scans_refused);
      count(imu ? reason::kImuTimeOutlier : reason::kScanTimeOutlier,
            describe(e) + " jumps away from the stream at the end of the input, unconfirmed: dropped");
    }
    s->held.clear();
  }
}

}  // namespace fuse::io

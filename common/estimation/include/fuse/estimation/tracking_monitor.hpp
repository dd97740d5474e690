// Tracking status: does the estimator still have a usable estimate? Judged from what every scan's
// LiDAR step reports (ScanReport: updated, re-localised, fit, converged, constraints, prior σ) and
// from the state tracker's events (data gap, clock step, restart); no ground truth needed.
//
//   tracking      the last scan of a confident prior was updated and fit the map well
//   relocalizing  the prior is uncertain (after a gap, a restart or a clock step) and scans are
//                 being re-localised against the map, not yet followed by a confident good fit
//   lost          no usable estimate: re-localisation keeps failing, no accepted LiDAR update for
//                 too long while scans arrive, scans keep fitting poorly (constraint starvation or
//                 a wrong pose), or the prior is more uncertain than local re-localisation can handle
//
// A lost estimator keeps trying: its owner re-localises each new scan from a widened prior
// (StateTracker::widen) until one is re-localised well; the scan after it, from the then
// confident prior, returns it to tracking if it fits well.
// The class only reads reports: fuse-run's Estimator feeds it, and a service can feed it the same
// reports (fuse-update computes them) or events (fuse-state sees corrections and IMU).
#pragma once

#include <string>
#include <vector>

#include "fuse/core/config.hpp"
#include "fuse/estimation/scan_report.hpp"

namespace fuse {

enum class TrackingStatus { kTracking, kRelocalizing, kLost };
const char* to_string(TrackingStatus status);

/// What the state tracker did that makes the prior uncertain.
enum class TrackingEvent {
  kDataGap,    ///< coasted across a data gap (IMU and/or scans missing)
  kClockStep,  ///< a sensor clock stepped: the state continues at the new time, uncertain
  kRestart,    ///< the state was restored or re-initialised (a restarted service)
};
const char* to_string(TrackingEvent event);

/// estimator.tracking. The figures behind the defaults: docs/architecture.md ("Tracking status").
struct TrackingConfig {
  /// A scan fits the map well when its matched points lie on their planes: match_fit (1 − mean
  /// truncated residual cost over the constrained points, τ = recovery.inlier_residual) at least
  /// this. Good runs of five scenes and two LiDARs: 0.54 at the lowest, medians 0.88–0.96, at most
  /// 2 scans in a row below 0.6; broken runs (a wrong extrinsic, an IMU dropout not coasted) 7–53.
  double min_fit = 0.6;
  /// Fewer constraints than this is constraint starvation: not a good fit (good runs: 477 at the
  /// lowest but one scan of 4 on the campus scene with a spinning LiDAR).
  int min_constraints = 50;
  /// Consecutive re-localised scans (uncertain prior) that fail (no good fit, or not converged)
  /// before lost (1 s at 10 Hz).
  int max_failed_relocalisations = 10;
  /// Consecutive updated scans of a confident prior without a good fit before lost.
  int max_poor_fits = 5;
  /// s: no scan with a good fit for longer than this while scans arrive: lost.
  double max_time_without_update_s = 2.0;
  /// m: a prior position σ above this is beyond local re-localisation (lost unless the scan fits).
  double max_position_std = 5.0;
  /// s: a run lost for longer than this in one episode has diverged (fuse-run exit code 3).
  double max_lost_s = 5.0;
  void load(ConfigNode& node);
};

class TrackingMonitor {
 public:
  /// A stretch of time not tracking, with why.
  struct Episode {
    TrackingStatus status;
    std::string reason;
    double t_begin = 0.0, t_end = 0.0;  ///< scan times (a clock step inside makes them differ from duration)
    double duration = 0.0;              ///< s, summed over the scans inside it
  };

  explicit TrackingMonitor(const TrackingConfig& config) : config_(config) {}

  /// One scan's LiDAR step.
  void on_scan(const ScanReport& report);
  /// A scan that arrived but was refused before the LiDAR step (by its time, say): it counts as
  /// one scan period (the spacing of the scans processed before) without a LiDAR update.
  void on_refused_scan();
  /// The state tracker's event at time t: the prior is uncertain, scans are to be re-localised.
  void on_event(TrackingEvent event, double t);

  TrackingStatus status() const { return status_; }
  /// Lost, and the last scan was not re-localised well: its owner should re-localise the next
  /// scan from a widened prior (StateTracker::widen). After a good re-localisation the next scan
  /// runs from the confident prior, to show whether it fits. Not when lost only because a
  /// confident prior keeps fitting poorly: re-localising such a prior from scratch lost a usable
  /// one (a spinning 32-beam LiDAR on the campus scene: ATE 0.35 -> 19 m), and helped none of the
  /// measured cases (a wrong extrinsic, a map that a fault polluted); its scans keep being updated.
  bool wants_relocalisation() const {
    return status_ == TrackingStatus::kLost && !relocalised_ && !poorly_fitting_;
  }
  /// Why the status is what it is (empty while tracking).
  const std::string& reason() const { return reason_; }
  /// Every stretch spent relocalizing or lost, the current one included.
  const std::vector<Episode>& episodes() const { return episodes_; }
  /// s: total time spent in a status, and the longest single episode in it.
  double time_in(TrackingStatus status) const;
  double longest(TrackingStatus status) const;

 private:
  void set(TrackingStatus status, const std::string& reason, double t);
  /// Adds the time since the previous scan to the current status.
  void advance(double t);

  TrackingConfig config_;
  TrackingStatus status_ = TrackingStatus::kTracking;
  std::string reason_;
  std::vector<Episode> episodes_;
  bool have_time_ = false;
  bool rebased_ = false;  ///< a clock step since the previous scan: no duration across it
  double last_t_ = 0.0;     ///< the newest scan time seen
  double since_good_ = 0.0;  ///< s since the last scan that fit well (or the first scan)
  int failed_relocalisations_ = 0, poor_fits_ = 0;
  bool relocalised_ = false;     ///< the last scan was re-localised well
  bool poorly_fitting_ = false;  ///< lost because confident scans keep fitting poorly
  std::size_t refused_ = 0;    ///< scans refused in a row
  double scan_period_ = 0.0;   ///< s: spacing of the last two scans processed
};

}  // namespace fuse

#include "fuse/estimation/tracking_monitor.hpp"

#include <algorithm>
#include <cmath>

#include "fuse/core/logging.hpp"

namespace fuse {

const char* to_string(TrackingStatus status) {
  switch (status) {
    case TrackingStatus::kTracking: return "tracking";
    case TrackingStatus::kRelocalizing: return "relocalizing";
    case TrackingStatus::kLost: return "lost";
  }
  return "unknown";
}

const char* to_string(TrackingEvent event) {
  switch (event) {
    case TrackingEvent::kDataGap: return "data gap";
    case TrackingEvent::kClockStep: return "clock step";
    case TrackingEvent::kRestart: return "restart";
  }
  return "unknown";
}

void TrackingConfig::load(ConfigNode& node) {
  node.get("min_fit", min_fit).get("min_constraints", min_constraints);
  node.get("max_failed_relocalisations", max_failed_relocalisations);
  node.get("max_poor_fits", max_poor_fits).get("max_time_without_update_s", max_time_without_update_s);
  node.get("max_position_std", max_position_std).get("max_lost_s", max_lost_s);
  node.check(std::isfinite(min_fit) && min_fit >= 0.0 && min_fit <= 1.0, "min_fit", "must be in [0, 1]");
  node.check(min_constraints >= 0, "min_constraints", "must be >= 0");
  node.check(max_failed_relocalisations >= 1, "max_failed_relocalisations", "must be >= 1");
  node.check(max_poor_fits >= 1, "max_poor_fits", "must be >= 1");
  node.check(std::isfinite(max_time_without_update_s) && max_time_without_update_s > 0.0, "max_time_without_update_s",
             "must be positive and finite");
  node.check(std::isfinite(max_position_std) && max_position_std > 0.0, "max_position_std", "must be positive and finite");
  node.check(std::isfinite(max_lost_s) && max_lost_s >= 0.0, "max_lost_s", "must be finite and >= 0");
  node.finish();
}

void TrackingMonitor::advance(double t) {
  if (have_time_ && !rebased_ && t > last_t_) {
    const double dt = t - last_t_;
    if (dt <= config_.max_time_without_update_s) scan_period_ = dt;
    // "Without a fit while scans arrive": a stretch in which no scan arrived at all (a LiDAR gap,
    // scans published while this fuse-update was down) counts as one scan period, not as time
    // spent failing to fit (a restarted fuse-update was declared lost on its second scan, and
    // the prior widened to a gap of unknown length let re-localisation flip the heading 180°).
    since_good_ += dt <= config_.max_time_without_update_s ? dt : scan_period_;
    if (status_ != TrackingStatus::kTracking) episodes_.back().duration += dt;
  }
  if (!have_time_ || rebased_ || t > last_t_) last_t_ = t;
  if (status_ != TrackingStatus::kTracking) episodes_.back().t_end = last_t_;
  have_time_ = true;
  rebased_ = false;
}

void TrackingMonitor::on_scan(const ScanReport& r) {
  advance(r.t);
  refused_ = 0;
  relocalised_ = false;
  // A good fit: the filter took the scan, enough of its points found a plane (no constraint
  // starvation), and the matched points lie on their planes.
  const bool fits = r.updated && r.constraints >= static_cast<std::size_t>(config_.min_constraints) &&
                    r.match_fit >= config_.min_fit;
  const std::string outcome =
      !r.updated ? std::string("no update")
                 : fmt::format("fit {:.2f}, {} constraints{}", r.match_fit, r.constraints, r.converged ? "" : ", not converged");
  if (r.recovery) {
    // A re-localisation (uncertain prior) succeeded when it converged to a good fit. The track is
    // back only once a scan of the then confident prior fits too (below).
    if (fits && r.converged) {
      since_good_ = 0.0;
      failed_relocalisations_ = 0;
      relocalised_ = true;
      const std::string why = "re-localised (" + outcome + "), waiting for a confident scan to fit the map";
      set(status_ == TrackingStatus::kLost ? TrackingStatus::kLost : TrackingStatus::kRelocalizing, why, r.t);
      return;
    }
    ++failed_relocalisations_;
    poorly_fitting_ = false;  // a re-localisation ran: the reason is now its outcome
    if (r.prior_position_std > config_.max_position_std) {
      set(TrackingStatus::kLost,
          fmt::format("the prior position sigma {:.1f} m is beyond local re-localisation (tracking.max_position_std) "
                      "and the scan does not fit ({})",
                      r.prior_position_std, outcome),
          r.t);
    } else if (failed_relocalisations_ > config_.max_failed_relocalisations) {
      set(TrackingStatus::kLost,
          fmt::format("re-localisation failed {} scans in a row (last: {})", failed_relocalisations_, outcome), r.t);
    } else if (status_ == TrackingStatus::kTracking) {
      set(TrackingStatus::kRelocalizing, "re-localising an uncertain prior (" + outcome + ")", r.t);
    }
  } else if (fits) {
    since_good_ = 0.0;
    failed_relocalisations_ = poor_fits_ = 0;
    set(TrackingStatus::kTracking, "", r.t);
    return;
  } else if (r.updated && ++poor_fits_ > config_.max_poor_fits) {
    if (status_ != TrackingStatus::kLost) poorly_fitting_ = true;
    set(TrackingStatus::kLost,
        fmt::format("{} scans in a row without a good fit (last: {}; tracking.min_fit {:.2f}, min_constraints {})",
                    poor_fits_, outcome, config_.min_fit, config_.min_constraints),
        r.t);
  }
  if (status_ != TrackingStatus::kLost && since_good_ > config_.max_time_without_update_s) {
    poorly_fitting_ = false;
    set(TrackingStatus::kLost,
        fmt::format("no scan has fit the map for {:.1f} s while scans arrive (last: {})", since_good_, outcome),
        r.t);
  }
}

void TrackingMonitor::on_refused_scan() {
  // A refused scan's stamp may be what is wrong with it: it counts as one scan period.
  since_good_ += scan_period_;
  if (status_ != TrackingStatus::kTracking) episodes_.back().duration += scan_period_;
  ++refused_;
  if (status_ != TrackingStatus::kLost && since_good_ > config_.max_time_without_update_s) {
    poorly_fitting_ = false;
    set(TrackingStatus::kLost,
        fmt::format("no scan has fit the map for {:.1f} s while scans arrive ({} in a row refused before the LiDAR "
                    "step: see the scan_* counters)",
                    since_good_, refused_),
        last_t_);
  }
}

void TrackingMonitor::on_event(TrackingEvent event, double t) {
  if (event == TrackingEvent::kClockStep) rebased_ = true;
  if (status_ == TrackingStatus::kLost) return;  // lost stays lost until a scan fits
  set(TrackingStatus::kRelocalizing, fmt::format("after a {} at t={:.3f}", to_string(event), t), t);
}

void TrackingMonitor::set(TrackingStatus status, const std::string& reason, double t) {
  if (status != TrackingStatus::kLost) poorly_fitting_ = false;
  if (status == status_) {
    if (status != TrackingStatus::kTracking) reason_ = reason;
    return;
  }
  if (status_ != TrackingStatus::kTracking) episodes_.back().t_end = t;
  auto log = logger("estimator");
  if (status == TrackingStatus::kTracking) {
    log->info("tracking again at t={:.3f} after {:.1f} s {} ({})", t, episodes_.back().duration, to_string(status_), reason_);
  } else {
    log->warn("{} at t={:.3f}: {}", to_string(status), t, reason);
  }
  status_ = status;
  reason_ = reason;
  if (status != TrackingStatus::kTracking) {
    episodes_.push_back({status, reason, t, t, 0.0});
    if (have_time_ && t > last_t_) last_t_ = t;  // the episode's duration counts from its start
  }
}

double TrackingMonitor::time_in(TrackingStatus status) const {
  double sum = 0.0;
  for (const Episode& e : episodes_) {
    if (e.status == status) sum += e.duration;
  }
  return sum;
}

double TrackingMonitor::longest(TrackingStatus status) const {
  double longest = 0.0;
  for (const Episode& e : episodes_) {
    if (e.status == status) longest = std::max(longest, e.duration);
  }
  return longest;
}

}  // namespace fuse

#include "fuse/core/time_gate.hpp"

#include <cmath>

namespace fuse {

namespace {
/// Two stamps closer than this are the same instant (1 µs: well below any sensor period).
constexpr double kSameTime = 1e-6;
/// Most samples a forward jump may wait for.
constexpr int kMaxConfirmSamples = 10;
}  // namespace

void TimeGateConfig::load(ConfigNode& node) {
  node.get("enabled", enabled).get("max_gap_s", max_gap_s).get("confirm_samples", confirm_samples);
  node.get("step_confirm_s", step_confirm_s).get("hold_gap_s", hold_gap_s);
  node.check(std::isfinite(max_gap_s) && max_gap_s >= 0.1 && max_gap_s <= 3600.0, "max_gap_s", "must be in [0.1, 3600] s");
  node.check(std::isfinite(hold_gap_s) && hold_gap_s > 0.0 && hold_gap_s < max_gap_s, "hold_gap_s",
             "must be in (0, max_gap_s) s");
  node.check(confirm_samples >= 1 && confirm_samples <= kMaxConfirmSamples, "confirm_samples",
             "must be in [1, " + std::to_string(kMaxConfirmSamples) + "]");
  node.check(std::isfinite(step_confirm_s) && step_confirm_s > 0.0 && step_confirm_s <= 60.0, "step_confirm_s",
             "must be in (0, 60] s");
  node.finish();
}

const char* to_string(TimeGate::Verdict verdict) {
  switch (verdict) {
    case TimeGate::Verdict::kAccept: return "accept";
    case TimeGate::Verdict::kClockStep: return "clock_step";
    case TimeGate::Verdict::kDuplicate: return "duplicate";
    case TimeGate::Verdict::kOutOfOrder: return "out_of_order";
    case TimeGate::Verdict::kOutlier: return "time_outlier";
  }
  return "unknown";
}

void TimeGate::reset(double t) {
  started_ = true;
  time_ = t;
  held_.clear();
}

void TimeGate::push(double t, std::vector<Decision>& out, std::optional<double> reference) {
  out.clear();
  if (!started_) {
    reset(t);
    out.push_back({Verdict::kAccept, t, 0.0});
    return;
  }
  if (!held_.empty()) {
    const double last = held_.back();
    if (t > last + kSameTime && t - last <= config_.max_gap_s) {
      // Continues the jump. Confirmed forward by confirm_samples samples after the first held one,
      // backward once the held samples span step_confirm_s of their own time.
      held_.push_back(t);
      const bool forward = held_.front() > time_;
      const bool confirmed = forward ? static_cast<int>(held_.size()) > config_.confirm_samples
                                     : held_.back() - held_.front() >= config_.step_confirm_s;
      if (confirmed) release(out);
      return;
    }
    // Refuted: the jump was an excursion of one or a few samples.
    for (double h : held_) out.push_back({Verdict::kOutlier, h, h - time_});
    held_.clear();
  }
  const std::optional<Decision> d = judge(t, reference);
  if (!d) return;  // t starts a jump: held, decided later
  if (d->verdict == Verdict::kAccept || d->verdict == Verdict::kClockStep) time_ = t;
  out.push_back(*d);
}

void TimeGate::confirm(std::vector<Decision>& out) {
  out.clear();
  if (!held_.empty()) release(out);
}

void TimeGate::release(std::vector<Decision>& out) {
  // A held step within G was a long data gap; beyond it, a clock step.
  const double step = held_.front() - time_;
  out.push_back({std::abs(step) > config_.max_gap_s ? Verdict::kClockStep : Verdict::kAccept, held_.front(), step});
  for (std::size_t i = 1; i < held_.size(); ++i) out.push_back({Verdict::kAccept, held_[i], held_[i] - held_[i - 1]});
  time_ = held_.back();
  held_.clear();
}

std::optional<TimeGate::Decision> TimeGate::judge(double t, std::optional<double> reference) {
  const double d = t - time_;
  if (std::abs(d) <= kSameTime) return Decision{Verdict::kDuplicate, t, d};
  if (!config_.enabled) return Decision{d > 0.0 ? Verdict::kAccept : Verdict::kOutOfOrder, t, d};
  if (d > 0.0 && (d <= config_.hold_gap_s || (reference && d <= config_.max_gap_s))) {
    return Decision{Verdict::kAccept, t, d};
  }
  if (d < 0.0 && d >= -config_.max_gap_s) return Decision{Verdict::kOutOfOrder, t, d};
  // A long gap (H < d ≤ G, without a reference) or a jump of more than G, either way.
  if (reference) {
    // The other clock decides: it made the same step (a clock step of both), or this one is wrong.
    const bool agrees = std::abs(t - *reference) <= config_.max_gap_s;
    return Decision{agrees ? Verdict::kClockStep : Verdict::kOutlier, t, d};
  }
  held_.push_back(t);  // the following samples decide
  return std::nullopt;
}

}  // namespace fuse

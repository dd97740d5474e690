// Time is checked like any other input: one gate per sensor stream judges each sample's stamp
// against the stream's time (the stamp of the last sample it accepted), so that one bad stamp
// cannot make the rest of the stream look out of order, and a clock that steps is followed.
//
// With G = max_gap_s (the longest data gap that is still coasted across), H = hold_gap_s and
// d = t − stream time:
//   |d| ≤ same-time tolerance   duplicate      dropped
//   0 < d ≤ H                   accept         (a step longer than the sensor period is a data gap:
//                                               the consumer coasts across it as before)
//   H < d ≤ G                   long gap:      held like a jump until `confirm_samples` samples
//                                               continue it, then accepted (a data gap); refuted,
//                                               an outlier (so that one sample stamped seconds ahead
//                                               cannot make the stream behind it out of order)
//   −G ≤ d < 0                  out of order   dropped
//   |d| > G                     jump:          held, with the samples that continue it (each within
//                                               G after the one before), until they confirm it:
//                                               forward, `confirm_samples` samples after it;
//                                               backward, samples spanning `step_confirm_s` (a step
//                                               back cannot be told from a burst of old stamps as
//                                               soon). Confirmed, it is a clock step: its first
//                                               sample starts the new time base and the held ones
//                                               pass. A sample that does not continue it refutes
//                                               it: the held samples are outliers (dropped), and
//                                               that sample is judged against the stream as usual.
// A reference time (the other sensor's clock, e.g. the IMU's for scans) decides a jump at once:
// within G of the reference it is a clock step that both clocks made, else an outlier. Only a
// jump holds samples: a normal stream passes each sample as it comes.
//
// The gate judges times only: the caller keeps the samples it pushed in a FIFO and takes one
// from its front for each decision (decisions come in push order).
#pragma once

#include <optional>
#include <vector>

#include "fuse/core/config.hpp"

namespace fuse {

/// estimator.clock: the time checks of every sensor stream.
struct TimeGateConfig {
  /// false: the old strict check only (a sample not after the last accepted one is dropped, any
  /// step forward is accepted at once): no outlier or clock step handling. A negative control.
  bool enabled = true;
  /// s: G, the longest step a stream may make and be a data gap (coasted across, LiDAR
  /// re-localised); a sample farther from the stream, either way, is a jump. Above the longest
  /// gap the estimator can coast (a 1.4 s gap is re-localised) and far below any plausible clock
  /// step (seconds to hours).
  double max_gap_s = 6.0;
  /// s: H, a forward step longer than this (and at most G) waits for the samples after it before it
  /// is taken as a data gap: a 10 ms delay at 200 Hz, only at such a step.
  double hold_gap_s = 0.5;
  /// Samples after a forward jump that must continue it before it is taken as a clock step
  /// (the jump's samples are held meanwhile: a delay of this many samples, only at a jump).
  int confirm_samples = 2;
  /// s: a backward jump is a clock step once the samples continuing it span this long of their
  /// own time (they are held meanwhile, and pass when it is confirmed).
  double step_confirm_s = 1.0;
  void load(ConfigNode& node);
};

class TimeGate {
 public:
  enum class Verdict {
    kAccept,      ///< in order (possibly after a data gap of at most G): use it
    kClockStep,   ///< the first sample of a new time base (|step| > G, confirmed): use it, re-base
    kDuplicate,   ///< same stamp as the stream: dropped
    kOutOfOrder,  ///< behind the stream by at most G: dropped
    kOutlier,     ///< away from the stream by more than G and refuted: dropped
  };
  struct Decision {
    Verdict verdict;
    double t;     ///< the sample's stamp
    double step;  ///< s: t − the stream's time before it
  };

  explicit TimeGate(const TimeGateConfig& config = {}) : config_(config) {}

  /// Judges a sample stamped t (finite). `out` is cleared and receives the decisions made now,
  /// in push order: those of samples held before (released or dropped), then this one's unless
  /// it is held in turn. `reference`: another clock's current time that confirms or refutes a
  /// jump at once.
  void push(double t, std::vector<Decision>& out, std::optional<double> reference = std::nullopt);
  /// Another clock confirms the held jump: `out` receives the held samples' decisions (the first
  /// a clock step), as if the samples after them had confirmed it. Nothing when none is held.
  void confirm(std::vector<Decision>& out);
  /// Starts the stream at time t, forgetting held samples (a restored state).
  void reset(double t);

  bool started() const { return started_; }
  /// The stamp of the last sample accepted (the stream's time).
  double time() const { return time_; }
  std::size_t held() const { return held_.size(); }
  /// The newest held sample's stamp, when a jump is held.
  std::optional<double> newest_held() const {
    return held_.empty() ? std::nullopt : std::optional<double>(held_.back());
  }
  const TimeGateConfig& config() const { return config_; }

 private:
  /// Judges t against the stream (no sample held); nullopt: t starts a jump and is held.
  std::optional<Decision> judge(double t, std::optional<double> reference);
  /// Passes the held samples on, the first as a clock step.
  void release(std::vector<Decision>& out);

  TimeGateConfig config_;
  bool started_ = false;
  double time_ = 0.0;
  std::vector<double> held_;  ///< a jump and the samples continuing it
};

/// Counter name of a verdict that drops or re-bases ("duplicate", "out_of_order",
/// "time_outlier", "clock_step"; "accept" for kAccept), to be prefixed with the stream ("imu_").
const char* to_string(TimeGate::Verdict verdict);

}  // namespace fuse

// TimeGate (fuse/core/time_gate.hpp): every verdict, jumps forward and backward, confirmation by
// the following samples or by a reference clock, clock steps, and that a normal stream (also with
// a data gap) passes every sample at once.
#include "fuse/core/time_gate.hpp"

#include <gtest/gtest.h>

#include "config_checks.hpp"

#include <algorithm>
#include <string>
#include <vector>

namespace fuse {
namespace {

using V = TimeGate::Verdict;
constexpr double kDt = 0.005;  // s: a 200 Hz stream
constexpr double kT0 = 1000.0;

struct Fed {
  std::vector<TimeGate::Decision> all;  ///< every decision, in order
  std::vector<std::size_t> when;        ///< index of the push that produced each decision
};

/// Pushes the stamps in order and collects every decision and the push that made it.
Fed feed(TimeGate& gate, const std::vector<double>& stamps, std::optional<double> reference = std::nullopt) {
  Fed f;
  std::vector<TimeGate::Decision> out;
  for (std::size_t i = 0; i < stamps.size(); ++i) {
    gate.push(stamps[i], out, reference);
    for (const auto& d : out) {
      f.all.push_back(d);
      f.when.push_back(i);
    }
  }
  return f;
}

std::vector<double> stream(double t0, int n, double dt = kDt) {
  std::vector<double> s;
  for (int i = 0; i < n; ++i) s.push_back(t0 + i * dt);
  return s;
}

std::vector<V> verdicts(const Fed& f) {
  std::vector<V> v;
  for (const auto& d : f.all) v.push_back(d.verdict);
  return v;
}

TEST(TimeGate, NormalStreamPassesEverySampleAtOnce) {
  TimeGate gate;
  const auto s = stream(kT0, 100);
  const Fed f = feed(gate, s);
  ASSERT_EQ(f.all.size(), s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    EXPECT_EQ(f.all[i].verdict, V::kAccept);
    EXPECT_EQ(f.when[i], i) << "sample " << i << " was delayed";
    EXPECT_DOUBLE_EQ(f.all[i].t, s[i]);
  }
  EXPECT_DOUBLE_EQ(gate.time(), s.back());
}

TEST(TimeGate, ShortDataGapIsAcceptedAtOnce) {
  TimeGateConfig c;
  c.hold_gap_s = 0.5;
  TimeGate gate(c);
  std::vector<double> s = stream(kT0, 10);
  s.push_back(s.back() + 0.4);  // a 0.4 s gap: coasted by the consumer, not held
  s.push_back(s.back() + kDt);
  const Fed f = feed(gate, s);
  ASSERT_EQ(f.all.size(), s.size());
  EXPECT_EQ(f.all[10].verdict, V::kAccept);
  EXPECT_EQ(f.when[10], 10u);
  EXPECT_NEAR(f.all[10].step, 0.4, 1e-9);
}

TEST(TimeGate, LongDataGapIsAcceptedOnceTheSamplesAfterItContinueIt) {
  TimeGateConfig c;
  c.max_gap_s = 6.0;
  c.hold_gap_s = 0.5;
  c.confirm_samples = 2;
  TimeGate gate(c);
  std::vector<double> s = stream(kT0, 10);
  s.push_back(s.back() + 4.9);  // a restarted driver's gap: within G, longer than H
  for (int i = 0; i < 3; ++i) s.push_back(s.back() + kDt);
  const Fed f = feed(gate, s);
  ASSERT_EQ(f.all.size(), s.size());
  EXPECT_EQ(f.all[10].verdict, V::kAccept) << "a data gap, not a clock step";
  EXPECT_EQ(f.when[10], 12u) << "held for confirm_samples samples";
  EXPECT_NEAR(f.all[10].step, 4.9, 1e-9);
  EXPECT_EQ(f.all[13].verdict, V::kAccept);
  EXPECT_EQ(f.when[13], 13u);
  EXPECT_DOUBLE_EQ(gate.time(), s.back());
}

TEST(TimeGate, IsolatedSampleAFewSecondsAheadIsAnOutlierNotAGap) {
  TimeGateConfig c;
  c.max_gap_s = 6.0;
  c.hold_gap_s = 0.5;
  TimeGate gate(c);
  std::vector<double> s = stream(kT0, 10);
  s.push_back(s.back() + 3.0);  // within G: once taken as a gap, it made 3 s of the stream "out of order"
  for (int i = 1; i <= 5; ++i) s.push_back(s[9] + i * kDt);
  const Fed f = feed(gate, s);
  ASSERT_EQ(f.all.size(), s.size());
  EXPECT_EQ(f.all[10].verdict, V::kOutlier);
  for (std::size_t i = 11; i < f.all.size(); ++i) EXPECT_EQ(f.all[i].verdict, V::kAccept) << i;
}

TEST(TimeGate, DuplicateAndOutOfOrderAreDropped) {
  TimeGate gate;
  const Fed f = feed(gate, {kT0, kT0 + kDt, kT0 + kDt, kT0 + 3 * kDt, kT0 + 2 * kDt, kT0 + 4 * kDt});
  EXPECT_EQ(verdicts(f), (std::vector<V>{V::kAccept, V::kAccept, V::kDuplicate, V::kAccept, V::kOutOfOrder, V::kAccept}));
  EXPECT_NEAR(f.all[4].step, -kDt, 1e-9);
  EXPECT_DOUBLE_EQ(gate.time(), kT0 + 4 * kDt);  // dropped samples do not move the stream
}

TEST(TimeGate, IsolatedForwardJumpIsHeldThenDroppedAsOutlier) {
  TimeGate gate;
  std::vector<double> s = stream(kT0, 10);
  s.push_back(s.back() + 10.0);  // one stamp 10 s ahead
  for (int i = 1; i <= 5; ++i) s.push_back(s[9] + (i + 1) * kDt);
  const Fed f = feed(gate, s);
  ASSERT_EQ(f.all.size(), s.size());
  EXPECT_EQ(f.all[10].verdict, V::kOutlier);
  EXPECT_EQ(f.when[10], 11u) << "decided by the sample after it";
  EXPECT_NEAR(f.all[10].step, 10.0, 1e-9);
  for (std::size_t i = 11; i < f.all.size(); ++i) {
    EXPECT_EQ(f.all[i].verdict, V::kAccept) << i;  // the stream goes on: nothing else refused
    EXPECT_EQ(f.when[i], i);
  }
}

TEST(TimeGate, TwoSamplesJumpingAreStillOutliersWithTwoConfirmationsNeeded) {
  TimeGateConfig c;
  c.confirm_samples = 2;
  TimeGate gate(c);
  std::vector<double> s = stream(kT0, 5);
  s.push_back(s.back() + 10.0);
  s.push_back(s.back() + kDt);      // a second sample continues the jump: one confirmation
  s.push_back(s[4] + kDt);          // back in the stream: both are outliers
  const Fed f = feed(gate, s);
  EXPECT_EQ(verdicts(f), (std::vector<V>{V::kAccept, V::kAccept, V::kAccept, V::kAccept, V::kAccept, V::kOutlier,
                                         V::kOutlier, V::kAccept}));
  EXPECT_EQ(f.when[5], 7u);
  EXPECT_EQ(f.when[6], 7u);
}

TEST(TimeGate, IsolatedBackwardJumpIsDroppedWhenTheStreamGoesOn) {
  TimeGate gate;
  std::vector<double> s = stream(kT0, 10);
  s.push_back(s.back() - 10.0);  // one stamp 10 s behind
  for (int i = 1; i <= 5; ++i) s.push_back(s[9] + i * kDt);
  const Fed f = feed(gate, s);
  ASSERT_EQ(f.all.size(), s.size());
  EXPECT_EQ(f.all[10].verdict, V::kOutlier);
  EXPECT_EQ(f.when[10], 11u);  // decided by the next sample, which itself is not delayed
  EXPECT_NEAR(f.all[10].step, -10.0, 1e-9);
  for (std::size_t i = 11; i < f.all.size(); ++i) {
    EXPECT_EQ(f.all[i].verdict, V::kAccept);
    EXPECT_EQ(f.when[i], i);
  }
}

TEST(TimeGate, ForwardClockStepIsConfirmedByTheFollowingSamples) {
  TimeGateConfig c;
  c.confirm_samples = 2;
  TimeGate gate(c);
  std::vector<double> s = stream(kT0, 10);
  const double step_at = s.back() + kDt + 100.0;
  for (int i = 0; i < 10; ++i) s.push_back(step_at + i * kDt);  // +100 s for the rest of the stream
  const Fed f = feed(gate, s);
  ASSERT_EQ(f.all.size(), s.size());  // nothing refused
  EXPECT_EQ(f.all[10].verdict, V::kClockStep);
  EXPECT_NEAR(f.all[10].step, 100.0 + kDt, 1e-9);
  EXPECT_EQ(f.when[10], 12u);  // held for the two samples that confirm it
  EXPECT_EQ(f.when[11], 12u);
  EXPECT_EQ(f.when[12], 12u);
  for (std::size_t i = 11; i < f.all.size(); ++i) EXPECT_EQ(f.all[i].verdict, V::kAccept);
  for (std::size_t i = 13; i < f.all.size(); ++i) EXPECT_EQ(f.when[i], i) << "after the step the stream flows again";
  EXPECT_DOUBLE_EQ(gate.time(), s.back());
}

TEST(TimeGate, BackwardClockStepIsHeldForStepConfirmSThenPassesWhole) {
  TimeGateConfig c;
  c.step_confirm_s = 1.0;
  TimeGate gate(c);
  std::vector<double> s = stream(kT0, 10);
  const double new_base = s.back() - 100.0;
  const int n = 300;  // 1.5 s of samples at the new (earlier) time
  for (int i = 0; i < n; ++i) s.push_back(new_base + i * kDt);
  const Fed f = feed(gate, s);
  ASSERT_EQ(f.all.size(), s.size());  // nothing refused
  EXPECT_EQ(f.all[10].verdict, V::kClockStep);
  EXPECT_NEAR(f.all[10].step, -100.0, 1e-9);
  // Released once the held samples span step_confirm_s (200 steps of 5 ms), all at once.
  const std::size_t confirmed_at = f.when[10];
  EXPECT_NEAR(s[confirmed_at] - new_base, 1.0, kDt + 1e-9);
  for (std::size_t i = 11; i < f.all.size(); ++i) {
    EXPECT_EQ(f.all[i].verdict, V::kAccept) << i;
    EXPECT_EQ(f.when[i], std::max(i, confirmed_at)) << i;
  }
}

TEST(TimeGate, ABurstOfOldStampsShorterThanStepConfirmSIsOutliers) {
  TimeGate gate;
  std::vector<double> s = stream(kT0, 10);
  for (int i = 0; i < 50; ++i) s.push_back(s[9] - 30.0 + i * kDt);  // 0.25 s of stamps 30 s old
  s.push_back(s[9] + kDt);
  const Fed f = feed(gate, s);
  ASSERT_EQ(f.all.size(), s.size());
  for (std::size_t i = 10; i < 60; ++i) EXPECT_EQ(f.all[i].verdict, V::kOutlier) << i;
  EXPECT_EQ(f.all[60].verdict, V::kAccept);
  EXPECT_DOUBLE_EQ(gate.time(), s[9] + kDt);
}

TEST(TimeGate, ReferenceClockDecidesAJumpAtOnce) {
  TimeGate gate;
  std::vector<TimeGate::Decision> out;
  gate.push(kT0, out, kT0);
  gate.push(kT0 + 0.1, out, kT0 + 0.1);
  // 10 s ahead of the stream, but the reference (the IMU) is not: an outlier, at once.
  gate.push(kT0 + 10.2, out, kT0 + 0.2);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].verdict, V::kOutlier);
  gate.push(kT0 + 0.3, out, kT0 + 0.3);
  EXPECT_EQ(out[0].verdict, V::kAccept);
  // Both clocks stepped by +100 s: a clock step, at once.
  gate.push(kT0 + 100.4, out, kT0 + 100.4);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].verdict, V::kClockStep);
  // And back by 100 s with the reference: a clock step too, no second of waiting.
  gate.push(kT0 + 0.5, out, kT0 + 0.5);
  EXPECT_EQ(out[0].verdict, V::kClockStep);
  EXPECT_EQ(gate.held(), 0u);
}

TEST(TimeGate, AnotherClockConfirmsAHeldJump) {
  TimeGate gate;
  std::vector<TimeGate::Decision> out;
  gate.push(kT0, out);
  gate.push(kT0 - 100.0, out);  // behind: held (it would take step_confirm_s of samples)
  gate.push(kT0 - 100.0 + kDt, out);
  EXPECT_TRUE(out.empty());
  ASSERT_TRUE(gate.newest_held());
  EXPECT_DOUBLE_EQ(*gate.newest_held(), kT0 - 100.0 + kDt);
  gate.confirm(out);  // e.g. a scan stamped at the same new time
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].verdict, V::kClockStep);
  EXPECT_EQ(out[1].verdict, V::kAccept);
  EXPECT_FALSE(gate.newest_held());
  gate.push(kT0 - 100.0 + 2 * kDt, out);
  EXPECT_EQ(out[0].verdict, V::kAccept);
  gate.confirm(out);  // nothing held: nothing happens
  EXPECT_TRUE(out.empty());
}

TEST(TimeGate, DisabledIsTheStrictOrderCheckOnly) {
  TimeGateConfig c;
  c.enabled = false;
  TimeGate gate(c);
  std::vector<double> s = stream(kT0, 5);
  s.push_back(s.back() + 10.0);  // accepted at once: every later sample is then behind it
  s.push_back(s[4] + kDt);
  const Fed f = feed(gate, s);
  EXPECT_EQ(verdicts(f), (std::vector<V>{V::kAccept, V::kAccept, V::kAccept, V::kAccept, V::kAccept, V::kAccept,
                                         V::kOutOfOrder}));
}

TEST(TimeGate, ResetStartsTheStreamAtTheGivenTime) {
  TimeGate gate;
  std::vector<TimeGate::Decision> out;
  gate.push(kT0, out);
  gate.push(kT0 + 50.0, out);  // held
  EXPECT_EQ(gate.held(), 1u);
  gate.reset(kT0 + 60.0);
  EXPECT_EQ(gate.held(), 0u);
  gate.push(kT0 + 60.0 + kDt, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].verdict, V::kAccept);
}

TEST(TimeGate, VerdictNamesAreTheCounterSuffixes) {
  EXPECT_EQ(std::string(to_string(V::kDuplicate)), "duplicate");
  EXPECT_EQ(std::string(to_string(V::kOutOfOrder)), "out_of_order");
  EXPECT_EQ(std::string(to_string(V::kOutlier)), "time_outlier");
  EXPECT_EQ(std::string(to_string(V::kClockStep)), "clock_step");
}

TEST(TimeGateConfig, BadValuesAreRefusedNamingTheKey) {
  expect_refused_naming_the_key<TimeGateConfig>({"max_gap_s: 0", "hold_gap_s: 0", "hold_gap_s: 7", "confirm_samples: 0", "step_confirm_s: 0", "typo: 1"});
}

}  // namespace
}  // namespace fuse

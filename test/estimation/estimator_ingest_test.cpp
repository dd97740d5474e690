// Estimator input validation (estimator.hpp/.cpp): bad IMU samples and scans are counted under
// the names used in estimator.cpp and never crash the estimator.
#include "fuse/estimation/estimator.hpp"
#include "fuse/estimation/state_tracker.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>

namespace fuse {
namespace {

constexpr double kImuDt = 0.005;

ImuSample still_imu(double t) {
  ImuSample s;
  s.t = t;
  s.accel = Eigen::Vector3d(0, 0, 9.81);
  return s;
}

std::uint64_t counter(const Estimator& est, const std::string& name) {
  const auto counts = est.counters();
  const auto it = counts.find(name);
  return it == counts.end() ? 0 : it->second;
}

constexpr int kInitSamples = 300;  // 1.5 s of still IMU (static initialisation needs 1 s by default)

/// Feeds the still samples; returns the time of the next (not yet fed) sample.
double initialise(Estimator& est) {
  for (int k = 0; k < kInitSamples; ++k) est.ingest(still_imu(k * kImuDt));
  EXPECT_TRUE(est.initialised());
  return kInitSamples * kImuDt;
}

TEST(EstimatorIngest, NonFiniteImuIsCounted) {
  Estimator est{EstimatorConfig{}};
  const double t = initialise(est);
  ImuSample bad = still_imu(t);
  bad.gyro.x() = std::numeric_limits<double>::quiet_NaN();
  est.ingest(bad);
  ImuSample bad_time = still_imu(std::numeric_limits<double>::infinity());
  est.ingest(bad_time);
  EXPECT_EQ(counter(est, "imu_not_finite"), 2u);
  est.ingest(still_imu(t));  // the next good sample at the same time is accepted
  EXPECT_EQ(counter(est, "imu_duplicate") + counter(est, "imu_out_of_order"), 0u);
  EXPECT_TRUE(est.query(t).ok());
  EXPECT_TRUE(est.query(t).x.all_finite());
}

TEST(EstimatorIngest, TimeGoingBackwardsIsRefused) {
  Estimator est{EstimatorConfig{}};
  initialise(est);
  const double newest = (kInitSamples - 1) * kImuDt;  // the last sample fed
  est.ingest(still_imu(newest - 0.1));
  est.ingest(still_imu(newest));  // equal time: not after the previous one
  EXPECT_EQ(counter(est, "imu_out_of_order"), 1u);
  EXPECT_EQ(counter(est, "imu_duplicate"), 1u);
  EXPECT_EQ(est.query(newest + 0.01).status, QueryStatus::kInFuture);  // nothing was propagated past it
}

TEST(EstimatorIngest, DataGapIsFlaggedAndBridged) {
  Estimator est{EstimatorConfig{}};
  initialise(est);
  constexpr double kGap = 0.5;  // s, above divergence.max_imu_gap = 0.1 s
  const double after_gap = (kInitSamples - 1) * kImuDt + kGap;
  est.ingest(still_imu(after_gap));
  EXPECT_EQ(counter(est, "imu_gap"), 1u);
  EXPECT_TRUE(est.query(after_gap).ok());  // the sample is still used
  EXPECT_LT(est.query(after_gap).x.v.norm(), 1e-6);
}

// Time faults in the IMU stream (StateTracker's TimeGate, estimator.clock): an isolated stamp
// 10 s ahead or behind is dropped and counted, and the stream goes on; a step that the following
// samples confirm is a clock step, after which the state continues at the new time, uncertain.
TEST(StateTrackerTime, IsolatedJumpsAreDroppedAndTheStreamGoesOn) {
  for (const double jump : {10.0, -10.0}) {
    StateTracker tracker{EstimatorConfig{}};
    for (int k = 0; k < kInitSamples; ++k) tracker.ingest(still_imu(k * kImuDt));
    ASSERT_TRUE(tracker.initialised());
    double t = kInitSamples * kImuDt;
    tracker.ingest(still_imu(t + jump));
    for (int k = 1; k <= 100; ++k) tracker.ingest(still_imu(t + k * kImuDt));
    EXPECT_EQ(tracker.counters().get("imu_time_outlier"), 1u) << "jump " << jump;
    EXPECT_EQ(tracker.counters().get("imu_out_of_order") + tracker.counters().get("imu_clock_step"), 0u);
    EXPECT_NEAR(tracker.history().newest().t, t + 100 * kImuDt, 1e-9) << "jump " << jump;
    EXPECT_TRUE(tracker.take_events().empty());
  }
}

TEST(StateTrackerTime, ConfirmedClockStepContinuesAtTheNewTimeUncertain) {
  EstimatorConfig config;
  StateTracker tracker{config};
  for (int k = 0; k < kInitSamples; ++k) tracker.ingest(still_imu(k * kImuDt));
  const double before = tracker.history().newest().t;
  const NavState x_before = tracker.history().newest().x;
  const double step_to = before + 100.0;
  for (int k = 0; k < 50; ++k) tracker.ingest(still_imu(step_to + k * kImuDt));
  EXPECT_EQ(tracker.counters().get("imu_clock_step"), 1u);
  EXPECT_EQ(tracker.counters().get("imu_time_outlier"), 0u);
  EXPECT_NEAR(tracker.history().newest().t, step_to + 49 * kImuDt, 1e-9);
  EXPECT_LT((tracker.history().newest().x.p - x_before.p).norm(), 0.01);  // continues from the last state
  // With the uncertainty of a gap of unknown length (divergence.unknown_gap_s): metres, not millimetres.
  const double pos_std = std::sqrt(tracker.history().newest().P(Idx::kPos, Idx::kPos));
  EXPECT_GT(pos_std, 0.5 * 0.5 * config.divergence.gap_accel_std * std::pow(config.divergence.unknown_gap_s, 2));
  const auto events = tracker.take_events();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, TrackingEvent::kClockStep);
}

// A scan stamped in the IMU's new time confirms a backward step at once (the IMU alone would wait
// for estimator.clock.step_confirm_s of samples).
TEST(StateTrackerTime, AScanConfirmsAStepBackAtOnce) {
  StateTracker tracker{EstimatorConfig{}};
  for (int k = 0; k < kInitSamples; ++k) tracker.ingest(still_imu(k * kImuDt));
  const double back_to = tracker.history().newest().t - 100.0;
  for (int k = 0; k < 10; ++k) tracker.ingest(still_imu(back_to + k * kImuDt));
  EXPECT_EQ(tracker.counters().get("imu_clock_step"), 0u);  // held: 50 ms of a 1 s confirmation
  EXPECT_FALSE(tracker.confirm_jump(back_to + 200.0));      // a scan in neither clock
  ASSERT_TRUE(tracker.confirm_jump(back_to + 10 * kImuDt + 0.05));
  EXPECT_EQ(tracker.counters().get("imu_clock_step"), 1u);
  EXPECT_EQ(tracker.counters().get("imu_time_outlier"), 0u);
  EXPECT_NEAR(tracker.history().newest().t, back_to + 9 * kImuDt, 1e-9);  // every held sample used
}

// coast_to: a scan ends while the IMU is silent; the history is coasted to it as across a data
// gap (constant velocity, gap covariance); when the IMU returns, propagation continues from there.
TEST(StateTrackerTime, CoastToBridgesASilentImuAndTheImuResumesFromThere) {
  EstimatorConfig config;
  StateTracker tracker{config};
  for (int k = 0; k < kInitSamples; ++k) tracker.ingest(still_imu(k * kImuDt));
  const double last_imu = tracker.history().newest().t;
  const double P_before = tracker.history().newest().P(Idx::kPos, Idx::kPos);
  EXPECT_FALSE(tracker.coast_to(last_imu - 0.1));  // not after the newest entry
  ASSERT_TRUE(tracker.coast_to(last_imu + 0.4));
  ASSERT_TRUE(tracker.coast_to(last_imu + 0.5));   // the next scan, IMU still silent
  EXPECT_NEAR(tracker.history().newest().t, last_imu + 0.5, 1e-12);
  EXPECT_EQ(tracker.counters().get("imu_gap"), 1u);  // one gap, however many scans coast it
  EXPECT_GT(tracker.history().newest().P(Idx::kPos, Idx::kPos), P_before);
  EXPECT_GT(tracker.history().newest().P(Idx::kRot, Idx::kRot), std::pow(config.divergence.gap_gyro_std * 0.4, 2));
  EXPECT_LT(tracker.history().newest().x.v.norm(), 1e-6);  // at rest it stays at rest
  EXPECT_DOUBLE_EQ(tracker.last_imu_time(), last_imu);
  const auto events = tracker.take_events();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, TrackingEvent::kDataGap);
  tracker.ingest(still_imu(last_imu + 0.45));  // inside the coasted span: dropped, counted
  EXPECT_EQ(tracker.counters().get("imu_older_than_state"), 1u);
  tracker.ingest(still_imu(last_imu + 0.505));  // resumes after it
  EXPECT_NEAR(tracker.history().newest().t, last_imu + 0.505, 1e-12);
  EXPECT_EQ(tracker.counters().get("imu_gap"), 1u);
}

// The first sample after a coasted gap closes the gap whatever the length of its last stretch:
// a scan coasted into the gap and corrected there, then the IMU resuming less than max_imu_gap
// later, still leaves that stretch's unmodelled motion in the covariance. (Taken as a plain IMU
// step, it left a prior of 0.003 rad after 0.1 s unmeasured: with the time offset estimated,
// samples 84 µs earlier fell under the threshold and the scan after the gap was pulled 2° off.)
TEST(StateTrackerTime, TheStretchAfterACoastedScanIsAGapHoweverShort) {
  for (const double remainder : {0.095, 0.105}) {
    SCOPED_TRACE("IMU resumes " + std::to_string(remainder) + " s after the coasted scan");
    EstimatorConfig config;
    ASSERT_LT(0.095, config.divergence.max_imu_gap);
    ASSERT_GT(0.105, config.divergence.max_imu_gap);
    StateTracker tracker{config};
    for (int k = 0; k < kInitSamples; ++k) tracker.ingest(still_imu(k * kImuDt));
    const double last_imu = tracker.history().newest().t, t_scan = last_imu + 0.2;
    ASSERT_TRUE(tracker.coast_to(t_scan));
    tracker.history().correct(t_scan, tracker.history().newest().x, 1e-8 * StateCovariance::Identity());
    tracker.ingest(still_imu(t_scan + remainder));
    const auto& resumed = tracker.history().newest();
    ASSERT_NEAR(resumed.t, t_scan + remainder, 1e-12);
    EXPECT_GT(resumed.P(Idx::kRot, Idx::kRot), std::pow(0.5 * config.divergence.gap_gyro_std * remainder, 2));
    EXPECT_GT(resumed.P(Idx::kPos, Idx::kPos), std::pow(0.25 * config.divergence.gap_accel_std * remainder * remainder, 2));
  }
}

// A correction older than a coasted data gap (a scan held during a restart, answered after the
// IMU resumed) re-propagates across the gap with the gap's variance and levelling applied again:
// the history is the same whichever arrived first, the correction or the IMU after the gap.
// (Re-propagating as if the gap had been measured left a prior of millimetres after seconds of
// unmeasured motion: the long chaos soak's drift after fuse-state and fuse-ingest died together.)
TEST(StateTrackerTime, ACorrectionOlderThanACoastedGapKeepsTheGapsUncertainty) {
  for (const bool scan_in_gap : {false, true}) {
    SCOPED_TRACE(scan_in_gap ? "a scan coasted into the gap" : "IMU resumes after the gap");
    EstimatorConfig config;
    StateTracker first{config}, late{config};  // correction before / after the IMU across the gap
    for (int k = 0; k < kInitSamples; ++k) {
      first.ingest(still_imu(k * kImuDt));
      late.ingest(still_imu(k * kImuDt));
    }
    const double t_c = first.history().newest().t - 0.1;
    NavState x_c = first.history().query(t_c).x;
    x_c.p += Eigen::Vector3d(0.05, -0.02, 0.01);
    x_c.R = x_c.R * so3::Exp(Eigen::Vector3d(0.02, -0.01, 0.0));  // a tilt the levelling sees
    const StateCovariance P_c = 1e-6 * StateCovariance::Identity();
    first.history().correct(t_c, x_c, P_c);
    const double last_imu = first.history().newest().t, after = last_imu + 2.0;
    for (StateTracker* tr : {&first, &late}) {
      if (scan_in_gap) {
        ASSERT_TRUE(tr->coast_to(last_imu + 1.0));
      }
      for (int k = 0; k < 5; ++k) {  // the samples after a forward step confirm it
        ImuSample resumed = still_imu(after + k * kImuDt);
        resumed.accel = Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitX()) * resumed.accel;
        tr->ingest(resumed);
      }
    }
    late.history().correct(t_c, x_c, P_c);
    const auto& a = first.history().newest();
    const auto& b = late.history().newest();
    EXPECT_NEAR(a.t, b.t, 1e-12);
    EXPECT_LT((a.x.p - b.x.p).norm(), 1e-9);
    EXPECT_LT((a.x.R - b.x.R).norm(), 1e-9);
    EXPECT_LT((a.P - b.P).cwiseAbs().maxCoeff(), 1e-9 * a.P.cwiseAbs().maxCoeff());
    // At least the variance of one second of unmeasured motion (without the step: 1e-6 m²).
    EXPECT_GT(b.P(Idx::kPos, Idx::kPos), std::pow(0.5 * config.divergence.gap_accel_std * 1.0 * 1.0, 2));
  }
}

// A scan held inside a coasted gap (fuse-state restored, the IMU of the gap lost with a killed
// ingest, the IMU resumed before fuse-update answered the held scans) gets the unmodelled motion
// of its part of the gap, and its correction restarts the count: the scan after the gap meets the
// uncertainty of the time since the last held scan, not of the whole gap. (The whole gap's σ of
// metres after held scans had tracked through it let the long chaos soak re-localise 4 m along
// the corridor.) Splitting the gap without a correction never makes its end more certain.
TEST(StateTrackerTime, AHeldScanInsideACoastedGapRestartsItsUncertainty) {
  EstimatorConfig config;
  StateTracker tracker{config};
  for (int k = 0; k < kInitSamples; ++k) tracker.ingest(still_imu(k * kImuDt));
  const double gap_from = tracker.history().newest().t, gap = 3.0;
  for (int k = 0; k < 5; ++k) tracker.ingest(still_imu(gap_from + gap + k * kImuDt));
  ASSERT_EQ(tracker.counters().get("imu_gap"), 1u);
  StateHistory& h = tracker.history();
  const double t_end = gap_from + gap;  // the first sample after the gap
  const auto V = [&](double dt) {
    return unmodelled_motion_variance(config.divergence.gap_accel_std, config.divergence.gap_gyro_std, dt);
  };
  const double whole = h.query(t_end).P(Idx::kPos, Idx::kPos);
  EXPECT_GT(whole, 0.99 * V(gap)(Idx::kPos));

  // Split (a prior read) inside the gap: its own part of the gap, and the end no more certain.
  const double t_mid = gap_from + 1.5;
  ASSERT_TRUE(h.ensure_entry(t_mid));
  // (beyond V, the initial covariance propagated over 1.5 s: a few centimetres at most)
  EXPECT_GT(h.query(t_mid).P(Idx::kPos, Idx::kPos), V(1.5)(Idx::kPos));
  EXPECT_LT(h.query(t_mid).P(Idx::kPos, Idx::kPos), V(1.5)(Idx::kPos) + 0.1);
  EXPECT_GT(h.query(t_mid).P(Idx::kRot, Idx::kRot), V(1.5)(Idx::kRot));
  EXPECT_LT(h.query(t_mid).P(Idx::kRot, Idx::kRot), V(1.5)(Idx::kRot) + 0.01);
  EXPECT_GE(h.query(t_end).P(Idx::kPos, Idx::kPos), whole);
  EXPECT_LT(h.query(t_end).P(Idx::kPos, Idx::kPos), 1.5 * whole);  // conservative, not unbounded

  // Held scans every 0.1 s through the gap, each corrected (the first at the gap's start): the
  // end is as uncertain as 0.1 s of unmeasured motion.
  h.correct(gap_from, h.query(gap_from).x, 1e-6 * StateCovariance::Identity());
  for (double t = gap_from + 0.1; t < t_end - 0.05; t += 0.1) {
    ASSERT_TRUE(h.ensure_entry(t));
    const StateQuery prior = h.query(t);
    EXPECT_LT(prior.P(Idx::kPos, Idx::kPos), V(0.1)(Idx::kPos) + 1e-5) << "prior at " << t - gap_from << " s into the gap";
    h.correct(t, prior.x, 1e-6 * StateCovariance::Identity());
  }
  const StateQuery after = h.query(t_end);
  EXPECT_LT(after.P(Idx::kPos, Idx::kPos), 1e-3) << "whole gap: " << whole;
  EXPECT_LT(after.P(Idx::kRot, Idx::kRot), V(0.15)(Idx::kRot) + 1e-5);
  EXPECT_GT(after.P(Idx::kRot, Idx::kRot), V(0.05)(Idx::kRot));  // the unmeasured rest still counts
}

// A posterior restored with no IMU sample before it (fuse-state and the sensor's ingest restarted
// together) coasts from its own attitude; a correction at its time arriving after the IMU resumed
// gives what restoring the corrected posterior gives (not the specific force of the attitude
// restored first: 0.2 m/s² of gravity per 1.2° of tilt).
TEST(StateTrackerTime, ARestoreWithoutImuCoastsFromTheCorrectedAttitude) {
  EstimatorConfig config;
  StateTracker restored{config}, corrected{config};
  const double t = 10.0;
  NavState x;
  x.v = Eigen::Vector3d(1.3, 0.0, 0.0);
  NavState x_c = x;
  x_c.R = so3::Exp(Eigen::Vector3d(0.0, 0.02, 0.0));
  const StateCovariance P = 1e-4 * StateCovariance::Identity();
  restored.restore(t, x, P, std::nullopt);
  corrected.restore(t, x_c, P, std::nullopt);
  for (int k = 0; k < 5; ++k) {
    ImuSample s = still_imu(t + 0.3 + k * kImuDt);
    s.accel = x_c.R.transpose() * s.accel;
    restored.ingest(s);
    corrected.ingest(s);
  }
  restored.history().correct(t, x_c, P);
  const auto& a = restored.history().newest();
  const auto& b = corrected.history().newest();
  EXPECT_LT((a.x.p - b.x.p).norm(), 1e-9);
  EXPECT_LT((a.x.v - b.x.v).norm(), 1e-9);
  EXPECT_LT((a.P - b.P).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_NEAR(b.x.v.x(), 1.3, 1e-3);  // coasted at constant velocity
}

TEST(AgreedRate, IsTheSmallerRateWhenBothAgreeInSignElseZero) {
  const Eigen::Vector3d w = agreed_rate(Eigen::Vector3d(0.5, -0.2, 0.3), Eigen::Vector3d(0.4, -0.6, -0.1));
  EXPECT_DOUBLE_EQ(w.x(), 0.4);   // a steady turn that slows: the smaller rate
  EXPECT_DOUBLE_EQ(w.y(), -0.2);  // same sign, negative
  EXPECT_DOUBLE_EQ(w.z(), 0.0);   // opposite signs: an oscillation, no rate assumed
  EXPECT_EQ(agreed_rate(Eigen::Vector3d::Zero(), Eigen::Vector3d(1, 1, 1)), Eigen::Vector3d::Zero());
}

/// Still IMU turning about z at rate w(t) (accelerometer reads gravity only).
ImuSample turning_imu(double t, double rate) {
  ImuSample s = still_imu(t);
  s.gyro.z() = rate;
  return s;
}

double yaw(const NavState& x) { return std::atan2(x.R(1, 0), x.R(0, 0)); }

/// Yaw change the estimator coasts across a gap of `gap` s after feeding `rate(t)` for 2 s.
double coasted_yaw(const std::function<double(double)>& rate, double gap) {
  Estimator est{EstimatorConfig{}};
  double t = initialise(est);
  for (; t < kInitSamples * kImuDt + 2.0; t += kImuDt) est.ingest(turning_imu(t, rate(t)));
  const double before_t = t - kImuDt;
  const double before = yaw(est.query(before_t).x);
  // The sample after the gap, and those that confirm it (a gap longer than clock.hold_gap_s waits
  // for clock.confirm_samples samples continuing it).
  for (int i = 0; i <= EstimatorConfig{}.clock.confirm_samples; ++i) {
    const double ti = before_t + gap + i * kImuDt;
    est.ingest(turning_imu(ti, rate(ti)));
  }
  EXPECT_EQ(counter(est, "imu_gap"), 1u);
  return yaw(est.query(before_t + gap).x) - before;
}

TEST(EstimatorIngest, AGapInASteadyTurnIsCoastedAtTheTurnRate) {
  constexpr double kRate = 0.5, kGap = 0.6;  // rad/s, s
  EXPECT_NEAR(coasted_yaw([](double) { return kRate; }, kGap), kRate * kGap, 0.01);
}

TEST(EstimatorIngest, AGapInASwayIsNotCoastedAtOneEndsRate) {
  // Sway at 2 Hz, 0.4 rad/s peak; the gap is one period, so both ends read the same positive
  // rate and the true yaw change across it is zero. Coasting at that end rate would turn by
  // 0.4 × 0.5 · sin(phase); the mean over the window before the gap (two periods) is ~0.
  constexpr double kPeak = 0.4, kPeriod = 0.5;
  auto sway = [](double t) { return kPeak * std::cos(2.0 * M_PI * t / kPeriod); };
  const double coasted = coasted_yaw(sway, kPeriod);
  EXPECT_LT(std::abs(coasted), 0.02) << "coasted yaw change " << coasted << " rad across a full sway period";
}

TEST(EstimatorIngest, EmptyAndBadScansAreCounted) {
  Estimator est{EstimatorConfig{}};
  LidarScan early;
  early.t_start = 0.0;
  early.t_end = 0.1;
  est.ingest(early);
  EXPECT_EQ(counter(est, "scan_before_init"), 1u);

  const double t = initialise(est);
  LidarScan empty;
  empty.t_start = t - 0.2;
  empty.t_end = t - 0.1;
  ScanReport rep;
  EXPECT_NO_THROW(rep = est.ingest(empty));
  EXPECT_EQ(counter(est, "scan_empty"), 1u);
  EXPECT_FALSE(rep.updated);
  EXPECT_EQ(rep.points_kept, 0u);

  LidarScan blind;  // only returns inside the blind zone (min_range)
  blind.t_start = t - 0.09;
  blind.t_end = t - 0.05;
  LidarPoint p;
  p.x = 0.1f;
  blind.points.assign(10, p);
  EXPECT_NO_THROW(est.ingest(blind));
  EXPECT_EQ(counter(est, "scan_empty"), 2u);

  LidarScan reversed;
  reversed.t_start = t;
  reversed.t_end = t - 0.01;
  est.ingest(reversed);
  EXPECT_EQ(counter(est, "scan_bad_time"), 1u);

  LidarScan old_scan;
  old_scan.t_start = t - 0.3;
  old_scan.t_end = t - 0.2;  // older than the last scan
  est.ingest(old_scan);
  EXPECT_EQ(counter(est, "scan_out_of_order"), 1u);
}

}  // namespace
}  // namespace fuse

namespace fuse {
namespace {

// level_with_accelerometer: a still sensor's specific force restores roll and pitch that a gap left
// wrong (up to tens of degrees), leaves the heading, and shrinks the tilt variance only.
TEST(LevelWithAccelerometer, RestoresTiltKeepsHeading) {
  const Eigen::Matrix3d R_true = (Eigen::AngleAxisd(2.0, Eigen::Vector3d::UnitZ()) *
                                  Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()) *
                                  Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitX())).toRotationMatrix();
  NavState x;
  x.R = R_true * so3::Exp(Eigen::Vector3d(0.5, -0.4, 0.0));  // ~37° of tilt error
  StateCovariance P = StateCovariance::Identity() * 1e-4;
  P.block<3, 3>(Idx::kRot, Idx::kRot) = Eigen::Matrix3d::Identity() * 0.35 * 0.35;
  const Eigen::Vector3d f = R_true.transpose() * -x.g;  // still: f = R⊤(−g)
  const Eigen::Vector3d heading_before = x.R.col(0);
  level_with_accelerometer(f, 0.01, x, P);
  const Eigen::Vector3d up(0, 0, 1);
  EXPECT_LT(std::acos(std::min(1.0, (x.R * f.normalized()).dot(up))), 0.02);  // levelled to ~1°
  // The heading (x axis projected on the horizontal plane) moved little compared with the tilt.
  auto heading = [](const Eigen::Vector3d& a) { return std::atan2(a.y(), a.x()); };
  EXPECT_LT(std::abs(heading(x.R.col(0)) - heading(heading_before)), 0.25);
  EXPECT_LT(P(Idx::kRot, Idx::kRot), 0.35 * 0.35);
  EXPECT_TRUE(P.allFinite());
  // No specific force: nothing to level with, nothing changes.
  const NavState y = x;
  level_with_accelerometer(Eigen::Vector3d::Zero(), 0.01, x, P);
  EXPECT_EQ(x.R, y.R);
}

}  // namespace
}  // namespace fuse

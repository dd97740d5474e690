// StateHistory (state_history.hpp): manifold interpolation, query status, ensure_entry and
// correct() with re-propagation of the stored IMU samples.
#include "fuse/estimation/state_history.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "test_helpers.hpp"

namespace fuse {
namespace {

constexpr double kDt = 0.005;
constexpr double kT0 = 100.0;

/// A varied IMU signal (rotating, accelerating) at time t.
ImuSample imu_at(double t) {
  ImuSample s;
  s.t = t;
  s.gyro = Eigen::Vector3d(0.3 * std::sin(t), 0.2 * std::cos(2 * t), 0.5);
  s.accel = Eigen::Vector3d(0.5 * std::cos(t), 0.2, 9.81 + 0.3 * std::sin(3 * t));
  return s;
}

StateCovariance initial_P() { return 1e-4 * StateCovariance::Identity(); }

/// A history reset at kT0 and fed `n` IMU samples after it.
StateHistory make_history(int n, double length_s = 5.0) {
  StateHistory h(StateHistoryConfig{length_s}, ImuNoiseConfig{});
  NavState x0;
  x0.v = Eigen::Vector3d(1, 0, 0);
  h.reset(kT0, x0, initial_P(), imu_at(kT0));
  for (int k = 1; k <= n; ++k) h.add_imu(imu_at(kT0 + k * kDt));
  return h;
}

void expect_same_state(const NavState& a, const NavState& b, double tol) {
  EXPECT_LT((a.p - b.p).norm(), tol);
  EXPECT_LT((a.R - b.R).norm(), tol);
  EXPECT_LT((a.v - b.v).norm(), tol);
  EXPECT_LT((a.bg - b.bg).norm(), tol);
  EXPECT_LT((a.ba - b.ba).norm(), tol);
}

// Between two entries the query is the geodesic: slerp of the attitude (checked with Eigen's
// quaternion slerp, an independent implementation) and lerp of position and velocity.
TEST(StateHistory, QueryBetweenEntriesIsSlerpAndLerp) {
  const StateHistory h = make_history(10);
  const auto entries = h.entries_between(kT0 + 3 * kDt, kT0 + 4 * kDt);
  ASSERT_EQ(entries.size(), 2u);
  const NavState& x0 = entries[0]->x;
  const NavState& x1 = entries[1]->x;
  for (double a : {0.0, 0.25, 0.5, 0.9}) {
    const StateQuery q = h.query(kT0 + (3 + a) * kDt);
    ASSERT_TRUE(q.ok());
    const Eigen::Quaterniond slerp = Eigen::Quaterniond(x0.R).slerp(a, Eigen::Quaterniond(x1.R));
    EXPECT_LT((q.x.R - slerp.toRotationMatrix()).norm(), 1e-12) << "a " << a;
    EXPECT_LT((q.x.p - ((1 - a) * x0.p + a * x1.p)).norm(), 1e-12);
    EXPECT_LT((q.x.v - ((1 - a) * x0.v + a * x1.v)).norm(), 1e-12);
    EXPECT_LT((q.P - ((1 - a) * entries[0]->P + a * entries[1]->P)).norm(), 1e-15);
  }
}

// A constant body rate is interpolated exactly: R(t) = R0·Exp(ω t) between the entries.
TEST(StateHistory, InterpolationIsExactForConstantRate) {
  const Eigen::Vector3d omega(0.4, -0.3, 1.2);
  StateHistory h(StateHistoryConfig{}, ImuNoiseConfig{});
  ImuSample s;
  s.t = kT0;
  s.gyro = omega;
  s.accel = Eigen::Vector3d(0, 0, 9.81);
  h.reset(kT0, NavState{}, initial_P(), s);
  s.t += 0.1;
  h.add_imu(s);
  const StateQuery q = h.query(kT0 + 0.037);
  EXPECT_LT(test::rotation_error(q.x.R, so3::Exp(omega * 0.037)), 1e-12);
}

// The angular velocity answered is the gyro sample held at t minus the gyro bias (ω = ω̃ − b_g),
// between samples and at the newest one.
TEST(StateHistory, AngularVelocityIsTheHeldGyroMinusTheBias) {
  StateHistory h(StateHistoryConfig{}, ImuNoiseConfig{});
  NavState x0;
  x0.bg = Eigen::Vector3d(0.01, -0.02, 0.005);
  h.reset(kT0, x0, initial_P(), imu_at(kT0));
  for (int k = 1; k <= 5; ++k) h.add_imu(imu_at(kT0 + k * kDt));
  for (const double a : {2.0, 2.5, 5.0}) {
    const StateQuery q = h.query(kT0 + a * kDt);
    ASSERT_TRUE(q.ok());
    const Eigen::Vector3d held = imu_at(kT0 + std::floor(a) * kDt).gyro;
    EXPECT_LT((q.omega - (held - x0.bg)).norm(), 1e-12) << "at " << a << " periods";
  }
}

TEST(StateHistory, StatusValues) {
  StateHistory empty(StateHistoryConfig{}, ImuNoiseConfig{});
  EXPECT_EQ(empty.query(kT0).status, QueryStatus::kNotInitialised);
  EXPECT_FALSE(empty.query(kT0).ok());

  constexpr int kSamples = 20;
  StateHistory h = make_history(kSamples);
  const double newest = kT0 + kSamples * kDt;
  EXPECT_EQ(h.query(kT0).status, QueryStatus::kCorrected);  // the reset state is a posterior
  EXPECT_EQ(h.query(kT0 + 2.5 * kDt).status, QueryStatus::kPropagated);
  EXPECT_EQ(h.query(newest).status, QueryStatus::kPropagated);
  EXPECT_EQ(h.query(kT0 - 0.01).status, QueryStatus::kTooOld);
  EXPECT_EQ(h.query(newest + 0.01).status, QueryStatus::kInFuture);
  EXPECT_FALSE(h.query(newest + 0.01).ok());

  const double t_corr = kT0 + 10 * kDt;
  h.correct(t_corr, h.query(t_corr).x, h.query(t_corr).P);
  EXPECT_EQ(h.query(t_corr - 3 * kDt).status, QueryStatus::kCorrected);
  EXPECT_EQ(h.query(t_corr).status, QueryStatus::kCorrected);
  EXPECT_EQ(h.query(t_corr + kDt).status, QueryStatus::kPropagated);
  EXPECT_STREQ(to_string(QueryStatus::kTooOld), "too_old");
}

// Entries older than length_s are dropped: they become too old.
TEST(StateHistory, BoundedLength) {
  constexpr double kLength = 0.5;
  const StateHistory h = make_history(400, kLength);  // 2 s of IMU
  EXPECT_NEAR(h.newest().t - h.oldest_time(), kLength, 2 * kDt);
  EXPECT_EQ(h.query(kT0 + 1.0).status, QueryStatus::kTooOld);
  EXPECT_TRUE(h.query(h.newest().t - 0.4).ok());
}

// Correcting a past entry and re-propagating equals propagating from the corrected state
// directly with the same IMU samples (trapezoidal average of consecutive samples).
TEST(StateHistory, CorrectionRepropagatesLaterEntries) {
  constexpr int kSamples = 60, kCorrected = 20;
  StateHistory h = make_history(kSamples);
  const double t_c = kT0 + kCorrected * kDt;
  NavState x_c = h.query(t_c).x;
  x_c.p += Eigen::Vector3d(0.1, -0.2, 0.05);
  x_c.v += Eigen::Vector3d(0.01, 0.0, -0.02);
  x_c.R = x_c.R * so3::Exp(Eigen::Vector3d(0.01, 0.02, -0.01));
  x_c.bg += Eigen::Vector3d(1e-3, 0, 0);
  const StateCovariance P_c = 2e-5 * StateCovariance::Identity();
  h.correct(t_c, x_c, P_c);

  NavState x = x_c;
  StateCovariance P = P_c;
  for (int k = kCorrected + 1; k <= kSamples; ++k) {
    const ImuSample a = imu_at(kT0 + (k - 1) * kDt), b = imu_at(kT0 + k * kDt);
    propagate(x, &P, 0.5 * (a.gyro + b.gyro), 0.5 * (a.accel + b.accel), b.t - a.t, ImuNoiseConfig{},
              ReadingChange{b.gyro - a.gyro});
  }
  expect_same_state(h.newest().x, x, 1e-12);
  EXPECT_LT((h.newest().P - P).cwiseAbs().maxCoeff(), 1e-15);
  expect_same_state(h.query(t_c).x, x_c, 1e-15);
}

// The time offset's column reads the low-passed rate (Entry::gyro_smooth). A car's turn (the yaw
// rate ramping up) under 37 Hz engine vibration: the attitude that readings shifted by a
// finite offset error e give differs from the unshifted one by about e times the change of the
// rate averaged over e, which the vibration hardly moves; the raw readings' change at the two
// ends of a scan is mostly vibration. With τ = 50 ms the column predicts the shifted attitude
// far better than with the raw readings (τ = 0), and the smoothed history telescopes: the
// column equals the low-pass's change over the scan.
TEST(StateHistory, TimeOffsetColumnReadsTheSmoothedRate) {
  constexpr double kShift = 0.03;  // s: an offset error the filter has to learn
  constexpr double kScan = 0.1;    // s
  const double t_start = kT0 + 0.5;  // the low-pass has settled
  const auto gyro_at = [](double t) {
    const double turn = 0.6 * std::clamp(t - kT0 - 0.2, 0.0, 0.6);  // yaw rate ramps at 0.6 rad/s²
    const double vib = 0.02 * std::sin(2.0 * M_PI * 37.0 * (t - kT0) + 0.7);
    return Eigen::Vector3d(0.6 * vib, vib, turn + 0.3 * vib);
  };
  const auto sample = [&](double t, double shift) {
    ImuSample s;
    s.t = t;
    s.gyro = gyro_at(t + shift);
    s.accel = Eigen::Vector3d(0.0, 0.0, 9.81);
    return s;
  };
  ImuNoiseConfig quiet;
  quiet.gyro_noise_density = quiet.accel_noise_density = 0.0;
  quiet.gyro_bias_random_walk = quiet.accel_bias_random_walk = 0.0;
  // The attitude at the scan end, from the scan start, and the column P(θ, t_d) with P = e_td e_tdᵀ
  // at the start.
  const auto run = [&](double tau, double shift, Eigen::Vector3d* column) {
    ImuNoiseConfig noise = quiet;
    noise.time_offset_rate_smoothing_s = tau;
    StateHistory h(StateHistoryConfig{5.0}, noise);
    h.reset(kT0, NavState{}, StateCovariance::Zero(), sample(kT0, shift));
    const int n_start = static_cast<int>(std::lround((t_start - kT0) / kDt));
    const int n_end = static_cast<int>(std::lround((t_start + kScan - kT0) / kDt));
    for (int k = 1; k <= n_start; ++k) h.add_imu(sample(kT0 + k * kDt, shift));
    StateCovariance P = StateCovariance::Zero();
    P(Idx::kTimeOffset, Idx::kTimeOffset) = 1.0;
    const NavState x0 = h.newest().x;
    const Eigen::Vector3d s0 = h.newest().gyro_smooth;
    h.correct(h.newest().t, x0, P);
    for (int k = n_start + 1; k <= n_end; ++k) h.add_imu(sample(kT0 + k * kDt, shift));
    if (column != nullptr) {
      *column = h.newest().P.block<3, 1>(Idx::kRot, Idx::kTimeOffset);
      // Telescoping: with the attitude nearly constant, Σ J_r·Δs ≈ s(end) − s(start).
      EXPECT_LT((*column - (h.newest().gyro_smooth - s0)).norm(), 0.05 * column->norm() + 1e-4);
    }
    return Eigen::Vector3d(so3::Log(x0.R.transpose() * h.newest().x.R));
  };
  Eigen::Vector3d raw, smooth;
  const Eigen::Vector3d unshifted = run(0.0, 0.0, &raw);
  run(0.05, 0.0, &smooth);
  const Eigen::Vector3d effect = (run(0.0, kShift, nullptr) - unshifted) / kShift;  // per second of offset
  ASSERT_GT(effect.norm(), 0.01);  // the turn's ramp shows
  const double err_raw = (raw - effect).norm(), err_smooth = (smooth - effect).norm();
  EXPECT_LT(err_smooth, 0.4 * effect.norm()) << "effect " << effect.transpose() << "\nsmoothed " << smooth.transpose();
  EXPECT_LT(err_smooth, 0.5 * err_raw) << "effect " << effect.transpose() << "\nraw " << raw.transpose();
}

// Entries inserted between samples (scan ends) do not advance the rate's low-pass: a history
// with scan entries holds the same low-passed readings at every sample, and the same time
// offset column at its newest entry, as one without; a second sample at the same instant
// leaves the low-pass as it was.
TEST(StateHistory, ScanEntriesDoNotAdvanceTheRateLowPass) {
  ImuNoiseConfig noise;
  noise.time_offset_rate_smoothing_s = 0.05;
  const auto history = [&]() {
    StateHistory h(StateHistoryConfig{5.0}, noise);
    StateCovariance P = initial_P();
    P(Idx::kTimeOffset, Idx::kTimeOffset) = 4e-4;
    h.reset(kT0, NavState{}, P, imu_at(kT0));
    return h;
  };
  StateHistory plain = history(), with_scans = history();
  for (int k = 1; k <= 40; ++k) {
    if (k % 10 == 3) {
      ASSERT_TRUE(with_scans.ensure_entry(kT0 + (k - 0.6) * kDt));  // after the newest sample
    }
    plain.add_imu(imu_at(kT0 + k * kDt));
    with_scans.add_imu(imu_at(kT0 + k * kDt));
    if (k % 10 == 7) {
      ASSERT_TRUE(with_scans.ensure_entry(kT0 + (k - 0.3) * kDt));  // between two samples
    }
  }
  EXPECT_GT(with_scans.size(), plain.size());
  for (int k = 0; k <= 40; ++k) {
    const double t = kT0 + k * kDt;
    const auto a = plain.entries_between(t, t), b = with_scans.entries_between(t, t);
    ASSERT_FALSE(a.empty() || b.empty());
    EXPECT_EQ(a.back()->gyro_smooth, b.back()->gyro_smooth) << "sample " << k;
  }
  // The attitude's column: the same up to the split's own integration (the held reading over
  // the first part of a split step), far from the double count a split advancing it would give.
  const Eigen::Vector3d col = plain.newest().P.block<3, 1>(Idx::kRot, Idx::kTimeOffset);
  const Eigen::Vector3d col_scans = with_scans.newest().P.block<3, 1>(Idx::kRot, Idx::kTimeOffset);
  EXPECT_LT((col - col_scans).norm(), 0.02 * col.norm()) << col.transpose() << "\n" << col_scans.transpose();
  const Eigen::Vector3d before = plain.newest().gyro_smooth;
  ImuSample again = imu_at(plain.newest().t);
  again.gyro += Eigen::Vector3d(0.5, -0.5, 0.5);
  plain.add_imu(again);
  EXPECT_EQ(plain.newest().gyro_smooth, before);
}

// A scan time between IMU samples: inserting the entry when the scan arrives before the next IMU
// sample (extrapolation, then add_imu) gives the same history as when the IMU sample arrives first
// (add_imu, then ensure_entry splitting the step). Both hold the older sample up to the scan time.
TEST(StateHistory, EnsureEntryIsIndependentOfArrivalOrder) {
  constexpr int kBefore = 10;
  const double t_scan = kT0 + (kBefore + 0.4) * kDt;
  const ImuSample next = imu_at(kT0 + (kBefore + 1) * kDt);
  const ImuSample after = imu_at(kT0 + (kBefore + 2) * kDt);

  StateHistory scan_first = make_history(kBefore);
  ASSERT_TRUE(scan_first.ensure_entry(t_scan));
  scan_first.add_imu(next);
  scan_first.add_imu(after);

  StateHistory imu_first = make_history(kBefore);
  imu_first.add_imu(next);
  ASSERT_TRUE(imu_first.ensure_entry(t_scan));
  imu_first.add_imu(after);

  ASSERT_EQ(scan_first.size(), imu_first.size());
  for (double t : {t_scan, next.t, after.t}) expect_same_state(scan_first.query(t).x, imu_first.query(t).x, 1e-12);
  EXPECT_LT((scan_first.newest().P - imu_first.newest().P).cwiseAbs().maxCoeff(), 1e-15);
}

TEST(StateHistory, EnsureEntryExistingAndTooOld) {
  StateHistory h = make_history(10);
  const std::size_t n = h.size();
  EXPECT_TRUE(h.ensure_entry(kT0 + 5 * kDt));  // already an entry
  EXPECT_EQ(h.size(), n);
  EXPECT_FALSE(h.ensure_entry(kT0 - 1.0));
  EXPECT_EQ(h.size(), n);
  EXPECT_TRUE(h.ensure_entry(kT0 + 5.5 * kDt));
  EXPECT_EQ(h.size(), n + 1);
}

// A static initialisation saw the sensor rest over [rest_since, t0]: an entry before t0 within
// that window is the initial state, and the step from it to t0 is motionless, so a correction
// there carries to t0 unchanged (only the covariance grows by the IMU noise of the step). Before
// the window, or once the rest's end is trimmed away, the history is too old as before.
TEST(StateHistory, EntriesWithinTheInitialRestAreTheInitialState) {
  StateHistory h(StateHistoryConfig{0.5}, ImuNoiseConfig{});
  NavState x0;
  x0.R = so3::Exp(Eigen::Vector3d(0.05, -0.03, 0.4));
  x0.bg = Eigen::Vector3d(0.002, -0.001, 0.003);
  x0.ba = Eigen::Vector3d(0.05, 0.02, -0.04);
  ImuSample held;
  held.t = kT0;
  held.gyro = x0.bg;
  held.accel = x0.R.transpose() * (-x0.g) + x0.ba;
  h.reset(kT0, x0, initial_P(), held, kT0 - 1.0);

  const double t_scan = kT0 - 5e-6;  // a scan ending at its last point, just before the init
  ASSERT_TRUE(h.ensure_entry(t_scan));
  EXPECT_EQ(h.oldest_time(), t_scan);
  expect_same_state(h.query(t_scan).x, x0, 1e-15);
  EXPECT_FALSE(h.ensure_entry(kT0 - 1.1));
  ASSERT_TRUE(h.ensure_entry(kT0 - 0.6));
  expect_same_state(h.query(kT0 - 0.3).x, x0, 1e-12);

  NavState corrected = x0;
  corrected.p = Eigen::Vector3d(0.02, -0.01, 0.005);
  corrected.R = so3::Exp(Eigen::Vector3d(0.0, 0.0, 0.01)) * x0.R;  // about the vertical: at rest still
  h.correct(kT0 - 0.6, corrected, initial_P());
  expect_same_state(h.query(kT0).x, corrected, 1e-9);
  EXPECT_GT(h.query(kT0).P(Idx::kVel, Idx::kVel), initial_P()(Idx::kVel, Idx::kVel));

  for (int k = 1; k <= 400; ++k) {  // 2 s of rest: the initialisation's entries are trimmed
    ImuSample s = held;
    s.t = kT0 + k * kDt;
    h.add_imu(s);
  }
  ASSERT_GT(h.oldest_time(), kT0);
  EXPECT_FALSE(h.ensure_entry(kT0 - 0.5));
  EXPECT_FALSE(h.ensure_entry(h.oldest_time() - 0.01));
}

// A clock step or a received slice knows no rest before its oldest entry.
TEST(StateHistory, NoRestBeforeAResetWithoutOne) {
  StateHistory h = make_history(10);
  EXPECT_FALSE(h.ensure_entry(kT0 - 5e-6));
  StateHistory with_rest(StateHistoryConfig{5.0}, ImuNoiseConfig{});
  with_rest.reset(kT0, NavState{}, initial_P(), imu_at(kT0), kT0 - 1.0);
  std::vector<StateHistory::Entry> slice{with_rest.newest()};
  with_rest.assign(slice, kT0);
  EXPECT_FALSE(with_rest.ensure_entry(kT0 - 5e-6));
}

// ensure_entry only inserts a (propagated) entry: no posterior exists at that time, so the status
// there must stay "propagated" (QueryStatus::kCorrected is "at or before the last LiDAR correction").
TEST(StateHistory, EnsureEntryDoesNotMarkTheStateCorrected) {
  StateHistory h = make_history(20);
  const double t_scan = kT0 + 10.5 * kDt;
  ASSERT_TRUE(h.ensure_entry(t_scan));
  EXPECT_EQ(h.last_correction_time(), kT0);
  EXPECT_EQ(h.query(t_scan).status, QueryStatus::kPropagated);
  EXPECT_EQ(h.query(kT0 + 5 * kDt).status, QueryStatus::kPropagated);
}

}  // namespace
}  // namespace fuse

namespace fuse {
namespace {

// measured_since: a step longer than max_step (a coasted data gap) ending inside (t0, t1) marks
// where measured motion starts; steps of the IMU period do not, nor does one ending at t1.
TEST(StateHistory, MeasuredSinceIsTheEndOfTheLatestLongStep) {
  StateHistory h = make_history(20);           // kT0 .. kT0 + 20 kDt, IMU-period steps
  h.add_imu(imu_at(kT0 + 20 * kDt + 0.5));      // a 0.5 s step: a gap
  const double gap_end = kT0 + 20 * kDt + 0.5;
  for (int k = 1; k <= 10; ++k) h.add_imu(imu_at(gap_end + k * kDt));
  const double t1 = gap_end + 10 * kDt;
  EXPECT_DOUBLE_EQ(h.measured_since(kT0, kT0 + 20 * kDt, 0.1), kT0);  // no long step: t0
  EXPECT_DOUBLE_EQ(h.measured_since(gap_end - 0.05, t1, 0.1), gap_end);   // step straddles t0
  EXPECT_DOUBLE_EQ(h.measured_since(kT0, t1, 0.1), gap_end);
  EXPECT_DOUBLE_EQ(h.measured_since(gap_end + kDt, t1, 0.1), gap_end + kDt);  // gap before t0
  EXPECT_DOUBLE_EQ(h.measured_since(kT0, t1, 1.0), kT0);  // a longer max_step: not a gap
  // A scan that lies inside the coasted step (it ends where the step ends) keeps its points: the
  // step is its constant-velocity motion, not a gap before measured motion.
  EXPECT_DOUBLE_EQ(h.measured_since(gap_end - 0.1, gap_end, 0.1), gap_end - 0.1);
}

}  // namespace
}  // namespace fuse

namespace fuse {
namespace {

/// A posterior at t: the history's own state there, moved (a LiDAR correction's stand-in).
NavState moved(const StateHistory& h, double t, double dx) {
  NavState x = h.query(t).x;
  x.p.x() += dx;
  x.v.y() += 0.1 * dx;
  return x;
}

// Lazy re-propagation changes when entries are recomputed, never what they hold: a run of
// corrections far in the past (fuse-state catching up on held scans), each followed by a
// split at the next scan end, then new IMU samples, gives bit-identical entries whether every
// step is read at once (eager, as in the single-process estimator) or only at the end.
TEST(StateHistory, LazyRepropagationGivesTheEagerNumbers) {
  constexpr int kSamples = 4000;  // 20 s
  StateHistory eager = make_history(kSamples, 40.0);
  StateHistory lazy = make_history(kSamples, 40.0);
  for (int k = 0; k < 50; ++k) {
    const double t = kT0 + 1.0 + 0.1 * k + 0.0123;  // scan ends between IMU samples
    for (StateHistory* h : {&eager, &lazy}) {
      ASSERT_TRUE(h->ensure_entry(t));
      const NavState x = moved(*h, t, 0.01 * (k % 7));
      h->correct(t, x, initial_P());
    }
    (void)eager.newest();  // eager: everything re-propagated at once
    EXPECT_GT(lazy.stale_entries(), StateHistory::kEagerRefresh) << "the lazy tail is refreshed too early";
  }
  for (int k = 1; k <= 100; ++k) {
    eager.add_imu(imu_at(kT0 + (kSamples + k) * kDt));
    (void)eager.newest();
    lazy.add_imu(imu_at(kT0 + (kSamples + k) * kDt));
  }
  ASSERT_EQ(eager.size(), lazy.size());
  const auto a = eager.entries_between(eager.oldest_time(), eager.newest_time());
  const auto b = lazy.entries_between(lazy.oldest_time(), lazy.newest_time());
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(lazy.stale_entries(), 0u);
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i]->t, b[i]->t);
    ASSERT_EQ(a[i]->x.p, b[i]->x.p) << "entry " << i;
    ASSERT_EQ(a[i]->x.R, b[i]->x.R) << "entry " << i;
    ASSERT_EQ(a[i]->x.v, b[i]->x.v) << "entry " << i;
    ASSERT_EQ(a[i]->P, b[i]->P) << "entry " << i;
  }
}

// Reading a time inside a stale tail refreshes up to that time only; trimming never loses the
// base the stale entries are recomputed from.
TEST(StateHistory, ReadsRefreshOnlyWhatTheyReadAndTrimKeepsTheBase) {
  StateHistory h = make_history(2000, 5.0);  // 10 s of IMU, 5 s kept
  const double t = h.newest_time() - 4.0;
  ASSERT_TRUE(h.ensure_entry(t));
  h.correct(t, moved(h, t, 0.5), initial_P());
  const std::size_t stale = h.stale_entries();
  EXPECT_GT(stale, 700u);
  ASSERT_TRUE(h.query(t + 0.5).ok());
  EXPECT_LT(h.stale_entries(), stale - 90);  // 0.5 s refreshed
  EXPECT_GT(h.stale_entries(), stale - 110);
  EXPECT_NEAR(h.fresh_time(), t + 0.5, 2 * kDt);
  // New samples push the window forward past the correction while the tail is stale.
  StateHistory reference = h;
  (void)reference.newest();
  for (int k = 1; k <= 1200; ++k) {
    const ImuSample s = imu_at(h.newest_time() + kDt);
    h.add_imu(s);
    reference.add_imu(s);
  }
  EXPECT_EQ(h.size(), reference.size());
  EXPECT_EQ(h.newest().x.p, reference.newest().x.p);
  EXPECT_EQ(h.newest().P, reference.newest().P);
}

}  // namespace
}  // namespace fuse

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
  EXPECT_EQ(counter(est, "imu_time_not_increasing"), 0u);
  EXPECT_TRUE(est.query(t).ok());
  EXPECT_TRUE(est.query(t).x.all_finite());
}

TEST(EstimatorIngest, TimeGoingBackwardsIsRefused) {
  Estimator est{EstimatorConfig{}};
  initialise(est);
  const double newest = (kInitSamples - 1) * kImuDt;  // the last sample fed
  est.ingest(still_imu(newest - 0.1));
  est.ingest(still_imu(newest));  // equal time: not after the previous one
  EXPECT_EQ(counter(est, "imu_time_not_increasing"), 2u);
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
  est.ingest(turning_imu(before_t + gap, rate(before_t + gap)));
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

// The zero-velocity update (estimator.zero_velocity): the Kalman posterior of v = 0 against an
// explicit oracle, the rest test on IMU windows whose motion is known, the config's checks, and
// a parked sensor in a street canyon (a floor and two walls along x: nothing in the scans pins x)
// whose accelerometer has a bias the filter does not know. Without the update the position
// slides along the street by ½·b·t²; with it the sensor stays where it is.
#include <gtest/gtest.h>

#include <random>

#include "fuse/estimation/lidar_updater.hpp"
#include "fuse/estimation/zero_velocity.hpp"
#include "test_helpers.hpp"
#include "../core/config_checks.hpp"

namespace fuse {
namespace {

TEST(ZeroVelocity, UpdateIsTheKalmanPosteriorOfZeroVelocity) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 5; ++trial) {
    const NavState x0 = test::random_state(rng);
    const StateCovariance P0 = test::random_covariance(rng, 0.1);
    const double sigma = 0.02;
    // Oracle: H = [0 … I₃ … 0] at δv, K = P Hᵀ (H P Hᵀ + σ² I)⁻¹, δx = K (0 − v), P' = (I − K H) P.
    Eigen::Matrix<double, 3, kStateDim> H = Eigen::Matrix<double, 3, kStateDim>::Zero();
    H.block<3, 3>(0, Idx::kVel).setIdentity();
    const Eigen::Matrix<double, kStateDim, 3> K =
        P0 * H.transpose() * (H * P0 * H.transpose() + sigma * sigma * Eigen::Matrix3d::Identity()).inverse();
    const StateVector dx = K * (-x0.v);
    const StateCovariance P_expected = (StateCovariance::Identity() - K * H) * P0;

    NavState x = x0;
    StateCovariance P = P0;
    zero_velocity_update(sigma, x, P);
    EXPECT_LT((x.boxminus(x0) - dx).norm(), 1e-9);
    EXPECT_LT((P - P_expected).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT(x.v.norm(), x0.v.norm());
    EXPECT_LT((P.block<3, 3>(Idx::kVel, Idx::kVel).trace()), 3.0 * sigma * sigma);
  }
}

constexpr double kMaxStep = 0.1;  // s: divergence.max_imu_gap

/// A history at rest from 0 (level, no bias, v = 0), then 200 Hz samples over (0, 0.5] from `imu`.
template <typename Imu>
StateHistory history_of(Imu imu) {
  StateHistory h(StateHistoryConfig{}, ImuNoiseConfig{});
  h.reset(0.0, NavState{}, StateCovariance::Identity() * 1e-6, test::at_rest());
  for (int k = 1; k <= 100; ++k) h.add_imu(imu(0.005 * k, k));
  return h;
}

/// Samples of a level sensor with a steady rate `gyro` and `push` added to its specific force.
auto steady(const Eigen::Vector3d& gyro, const Eigen::Vector3d& push) {
  return [gyro, push](double t, int) {
    ImuSample s = test::at_rest(t);
    s.gyro = gyro;
    s.accel += push;
    return s;
  };
}

RestCheck rest_over(const StateHistory& h, double t0, double t1) {
  return check_rest(imu_window(h, t0, t1, kMaxStep), h.query(t1).x, ZeroVelocityConfig{});
}

TEST(ZeroVelocity, RestCheckTellsRestFromMotion) {
  const ZeroVelocityConfig c;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 1.0);
  const auto still = [&](double t, int) {
    ImuSample s = test::at_rest(t);
    s.gyro = 0.002 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    s.accel += 0.02 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    return s;
  };
  const RestCheck rest = rest_over(history_of(still), 0.4, 0.5);
  EXPECT_TRUE(rest.at_rest) << rest.rate << " " << rest.accel << " " << rest.gyro_std << " " << rest.accel_std;

  // Accelerating at 1 m/s² from rest: still slow over its first 0.1 s, but not resting.
  const RestCheck pull = rest_over(history_of(steady(Eigen::Vector3d::Zero(), Eigen::Vector3d(1.0, 0.0, 0.0))), 0.0, 0.1);
  EXPECT_FALSE(pull.at_rest);
  EXPECT_LE(pull.speed, c.max_speed);
  EXPECT_NEAR(pull.accel, 0.95, 1e-6);  // the rest sample at 0 holds over the window's first 5 ms

  // Turning on the spot at 0.1 rad/s.
  const RestCheck turn = rest_over(history_of(steady(Eigen::Vector3d(0.0, 0.0, 0.1), Eigen::Vector3d::Zero())), 0.4, 0.5);
  EXPECT_FALSE(turn.at_rest);
  EXPECT_NEAR(turn.rate, 0.1, 1e-9);

  // Swaying: ±0.5 m/s² alternating averages to rest but spreads by 0.5.
  const auto swaying = [](double t, int k) {
    ImuSample s = test::at_rest(t);
    s.accel.y() = (k % 2 == 0) ? 0.5 : -0.5;
    return s;
  };
  const RestCheck sway = rest_over(history_of(swaying), 0.4, 0.5);
  EXPECT_FALSE(sway.at_rest);
  EXPECT_LE(sway.accel, c.max_accel);
  EXPECT_NEAR(sway.accel_std, 0.5, 0.02);

  // Moving at a steady 1 m/s on a smooth road reads as still to the IMU: the prior's speed tells.
  StateHistory cruise(StateHistoryConfig{}, ImuNoiseConfig{});
  NavState moving;
  moving.v = Eigen::Vector3d(1.0, 0.0, 0.0);
  cruise.reset(0.0, moving, StateCovariance::Identity() * 1e-6, test::at_rest());
  for (int k = 1; k <= 100; ++k) cruise.add_imu(test::at_rest(0.005 * k));
  const RestCheck cr = rest_over(cruise, 0.4, 0.5);
  EXPECT_FALSE(cr.at_rest);
  EXPECT_NEAR(cr.speed, 1.0, 1e-6);
  EXPECT_LT(cr.accel, 1e-6);

  // The IMU silent over (0.3, 0.45): a window over the gap was not measured, whatever the samples
  // on either side say (the sample before it would be held as if the sensor still rested).
  StateHistory gap(StateHistoryConfig{}, ImuNoiseConfig{});
  gap.reset(0.0, NavState{}, StateCovariance::Identity() * 1e-6, test::at_rest());
  for (int k = 1; k <= 100; ++k) {
    if (k <= 60 || k >= 90) gap.add_imu(test::at_rest(0.005 * k));
  }
  ASSERT_TRUE(gap.ensure_entry(0.4));
  const ImuWindow over_gap = imu_window(gap, 0.35, 0.5, kMaxStep);
  EXPECT_FALSE(over_gap.measured);
  EXPECT_FALSE(check_rest(over_gap, gap.query(0.5).x, c).at_rest);
  EXPECT_TRUE(imu_window(gap, 0.2, 0.3, kMaxStep).measured);
  EXPECT_TRUE(rest_over(gap, 0.2, 0.3).at_rest);
}

TEST(ZeroVelocity, WindowWeighsSamplesByTheTimeTheyHold) {
  // 0.5 rad/s about z over (0, 0.25], 0 after; an extra entry splits the window: the window
  // [0.2, 0.3] holds the same mean whatever the entries.
  const auto step = [](double t, int) {
    ImuSample s = test::at_rest(t);
    s.gyro.z() = t < 0.25 + 1e-9 ? 0.5 : 0.0;
    return s;
  };
  StateHistory h = history_of(step);
  const ImuWindow before = imu_window(h, 0.2, 0.3, kMaxStep);
  ASSERT_TRUE(h.ensure_entry(0.2525));
  const ImuWindow after = imu_window(h, 0.2, 0.3, kMaxStep);
  EXPECT_NEAR(before.duration, 0.1, 1e-9);
  EXPECT_NEAR(before.mean_gyro.z(), after.mean_gyro.z(), 1e-12);
  // The sample at 0.25 (0.5) holds over [0.25, 0.255): 0.5 for 0.055 s of the 0.1 s, 0 after.
  EXPECT_NEAR(before.mean_gyro.z(), 0.5 * 0.55, 1e-9);
  EXPECT_NEAR(before.gyro_std, 0.5 * std::sqrt(0.55 * 0.45), 1e-9);
}

TEST(ZeroVelocityConfig, RefusesBadValuesNamingTheKey) {
  expect_refused_naming_the_key<ZeroVelocityConfig>({"max_speed: -1", "max_rate: .nan", "max_accel: 10",
                                                     "max_gyro_std: -0.1", "max_accel_std: 9", "velocity_std: 0",
                                                     "velocity_std: 2", "speed: 1"});
}

// A street canyon seen from its middle: the floor z = −1.5 and walls y = ±5 along x over
// [−10, 10]. Points 0.25 m apart.
LidarScan canyon(double t) {
  LidarScan scan;
  scan.t_start = t - 0.1;
  scan.t_end = t;
  const auto add = [&](double x, double y, double z) {
    LidarPoint p;
    p.x = static_cast<float>(x);
    p.y = static_cast<float>(y);
    p.z = static_cast<float>(z);
    scan.points.push_back(p);
  };
  for (double x = -10.0; x <= 10.0; x += 0.25) {
    for (double y = -4.75; y < 5.0; y += 0.25) add(x, y, -1.5);
    for (double z = -1.25; z < 3.0; z += 0.25) {
      add(x, -5.0, z);
      add(x, 5.0, z);
    }
  }
  return scan;
}

struct Parked {
  double x_drift = 0.0;  ///< m: |p_x| after 3 s at rest (the truth is 0)
  std::uint64_t updates = 0;
};

/// Parked for 3 s with an accelerometer bias of 0.05 m/s² along the street that the filter starts
/// from zero with σ 0.1 m/s² (initial_covariance.accel_bias_std).
Parked park(bool zero_velocity) {
  EstimatorConfig config;
  config.preprocess.deskew = false;
  config.zero_velocity.enabled = zero_velocity;
  LidarUpdater updater(config);
  StateHistory history(config.history, config.imu);
  StateCovariance P = StateCovariance::Identity() * 1e-6;
  P.block<3, 3>(Idx::kVel, Idx::kVel) = Eigen::Matrix3d::Identity() * 1e-4;
  P.block<3, 3>(Idx::kBa, Idx::kBa) = Eigen::Matrix3d::Identity() * 0.01;
  ImuSample biased = test::at_rest(0.0);
  biased.accel.x() = 0.05;
  history.reset(0.0, NavState{}, P, biased);
  for (int k = 1; k <= 600; ++k) {
    biased.t = 0.005 * k;
    history.add_imu(biased);
    if (k % 20 == 0) {
      EXPECT_TRUE(history.ensure_entry(biased.t));
      updater.process(canyon(biased.t), history);
    }
  }
  Parked out;
  out.x_drift = std::abs(history.query(3.0).x.p.x());
  out.updates = updater.counters().get("zero_velocity_updates");
  return out;
}

TEST(ZeroVelocity, AParkedSensorStaysWhereTheScansCannotHoldIt) {
  const Parked free = park(false);
  const Parked held = park(true);
  EXPECT_EQ(free.updates, 0u);
  EXPECT_GE(held.updates, 29u);
  // ½·0.05·3² = 0.225 m unmeasured; the walls along x cannot stop it.
  EXPECT_GT(free.x_drift, 0.1);
  EXPECT_LT(held.x_drift, 0.01);
}

}  // namespace
}  // namespace fuse

// The ideal IMU integrates to the ground truth: RK4 over pairs of 200 Hz samples (the middle
// sample is the midpoint), from the true initial state, over 25 s of each walking scenario.
// Also the static start of the noisy IMU: gyro ~ bias, accel ~ -R^T g + bias.
#include <gtest/gtest.h>

#include <cmath>

#include "fuse/sim/imu_model.hpp"
#include "fuse/sim/scenario.hpp"

using namespace fuse::sim;

namespace {

struct NavState {
  Eigen::Quaterniond q;
  Eigen::Vector3d v, p;
};
struct NavDerivative {
  Eigen::Vector4d dq;
  Eigen::Vector3d dv, dp;
};

// q' = 1/2 q (0, w), v' = R a + g, p' = v.
NavDerivative derivative(const NavState& x, const fuse::ImuSample& m) {
  const Eigen::Quaterniond w(0.0, m.gyro.x(), m.gyro.y(), m.gyro.z());
  NavDerivative d;
  d.dq = 0.5 * (x.q * w).coeffs();
  d.dv = x.q.normalized() * m.accel + kGravityWorld;
  d.dp = x.v;
  return d;
}

NavState advance(const NavState& x, const NavDerivative& d, double h) {
  NavState y;
  y.q.coeffs() = x.q.coeffs() + h * d.dq;
  y.v = x.v + h * d.dv;
  y.p = x.p + h * d.dp;
  return y;
}

// One RK4 step of length 2 dt using the samples at t, t + dt (midpoint) and t + 2 dt.
NavState rk4(const NavState& x, const fuse::ImuSample& m0, const fuse::ImuSample& m1, const fuse::ImuSample& m2,
             double h) {
  const NavDerivative k1 = derivative(x, m0);
  const NavDerivative k2 = derivative(advance(x, k1, h / 2), m1);
  const NavDerivative k3 = derivative(advance(x, k2, h / 2), m1);
  const NavDerivative k4 = derivative(advance(x, k3, h), m2);
  NavState y;
  y.q.coeffs() = x.q.coeffs() + h / 6 * (k1.dq + 2 * k2.dq + 2 * k3.dq + k4.dq);
  y.q.normalize();
  y.v = x.v + h / 6 * (k1.dv + 2 * k2.dv + 2 * k3.dv + k4.dv);
  y.p = x.p + h / 6 * (k1.dp + 2 * k2.dp + 2 * k3.dp + k4.dp);
  return y;
}

}  // namespace

class SimImuConsistency : public ::testing::TestWithParam<std::string> {};

TEST_P(SimImuConsistency, IdealImuIntegratesToGroundTruth) {
  const Scenario s = make_scenario(GetParam(), 5, 6);
  const Trajectory& tr = *s.trajectory;
  const double rate = 200.0, dt = 1.0 / rate, span = 25.0;
  const TrajectoryState s0 = tr.state(tr.t_begin());
  NavState x{Eigen::Quaterniond(s0.R), s0.v, s0.p};
  const int steps = static_cast<int>(span * rate / 2);
  double max_pos = 0.0, max_rot_deg = 0.0, travelled = 0.0;
  Eigen::Vector3d previous = s0.p;
  fuse::ImuSample m0 = ideal_imu(s0);
  for (int k = 0; k < steps; ++k) {
    const double t = tr.t_begin() + 2 * k * dt;
    const fuse::ImuSample m1 = ideal_imu(tr.state(t + dt)), m2 = ideal_imu(tr.state(t + 2 * dt));
    x = rk4(x, m0, m1, m2, 2 * dt);
    m0 = m2;
    const TrajectoryState truth = tr.state(t + 2 * dt);
    max_pos = std::max(max_pos, (x.p - truth.p).norm());
    max_rot_deg = std::max(max_rot_deg, Eigen::AngleAxisd(x.q.toRotationMatrix().transpose() * truth.R).angle() * 180 / M_PI);
    travelled += (truth.p - previous).norm();
    previous = truth.p;
  }
  EXPECT_GT(travelled, 5.0) << "the trajectory should move during the test";
  EXPECT_LT(max_pos, 0.01) << GetParam();
  EXPECT_LT(max_rot_deg, 0.01) << GetParam();
  RecordProperty("max_position_error_m", std::to_string(max_pos));
  RecordProperty("max_rotation_error_deg", std::to_string(max_rot_deg));
  std::printf("%s: 25 s RK4 of the ideal IMU: max position error %.2e m, max rotation error %.2e deg\n",
              GetParam().c_str(), max_pos, max_rot_deg);
}

INSTANTIATE_TEST_SUITE_P(Scenarios, SimImuConsistency,
                         ::testing::Values("corridor", "stairs", "room", "campus", "urban"));

TEST(SimImu, StaticStartMeasuresBiasAndGravity) {
  const Scenario s = make_scenario("corridor", 2, 9);
  const Trajectory& tr = *s.trajectory;
  ImuSimulator imu(ImuNoiseConfig{}, 9);
  const Eigen::Vector3d bg = imu.initial_gyro_bias(), ba = imu.initial_accel_bias();
  EXPECT_GT(bg.norm(), 1e-4);  // biases are not zero
  EXPECT_GT(ba.norm(), 1e-3);
  Eigen::Vector3d gyro_sum = Eigen::Vector3d::Zero(), accel_sum = Eigen::Vector3d::Zero();
  const int n = 400;  // the first 2 s at 200 Hz
  for (int i = 0; i < n; ++i) {
    const fuse::ImuSample m = imu.measure(tr.state(tr.t_begin() + i / 200.0));
    EXPECT_EQ(m.sequence, static_cast<std::uint64_t>(i));
    gyro_sum += m.gyro;
    accel_sum += m.accel;
  }
  const Eigen::Matrix3d R = tr.state(tr.t_begin()).R;
  EXPECT_LT((gyro_sum / n - bg).norm(), 3e-4);
  EXPECT_LT((accel_sum / n - (-R.transpose() * kGravityWorld + ba)).norm(), 3e-3);
}

TEST(SimImu, NoiseMatchesDensities) {
  const Scenario s = make_scenario("corridor", 2, 9);
  ImuNoiseConfig cfg;
  ImuSimulator imu(cfg, 11);
  const TrajectoryState x = s.trajectory->state(s.trajectory->t_begin());
  double g2 = 0.0, a2 = 0.0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d bg = imu.gyro_bias(), ba = imu.accel_bias();
    const fuse::ImuSample m = imu.measure(x);
    const fuse::ImuSample ideal = ideal_imu(x);
    g2 += (m.gyro - ideal.gyro - bg).squaredNorm();
    a2 += (m.accel - ideal.accel - ba).squaredNorm();
  }
  const double sg = std::sqrt(g2 / (3 * n)), sa = std::sqrt(a2 / (3 * n));
  EXPECT_NEAR(sg, cfg.gyro_noise_density * std::sqrt(cfg.rate_hz), 0.03 * sg);
  EXPECT_NEAR(sa, cfg.accel_noise_density * std::sqrt(cfg.rate_hz), 0.03 * sa);
}

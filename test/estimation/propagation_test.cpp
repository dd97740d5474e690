// IMU propagation (imu_propagation.hpp) against analytic motion, the error-state Jacobian F
// against numeric differentiation, and the covariance against a Monte-Carlo of propagate().
#include "fuse/estimation/imu_propagation.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>

#include "test_helpers.hpp"

namespace fuse {
namespace {

constexpr double kImuRate = 200.0;
constexpr double kDt = 1.0 / kImuRate;
constexpr double kGravity = 9.81;

ImuNoiseConfig zero_noise() {
  ImuNoiseConfig n;
  n.gyro_noise_density = n.accel_noise_density = n.gyro_bias_random_walk = n.accel_bias_random_walk = 0.0;
  return n;
}

// (a) At rest the ideal accelerometer measures the specific force f = Rᵀ(−g) (+ b_a) and the
// gyro measures b_g: the state must not move for 10 s.
TEST(Propagation, AtRestWithGravityStaysStill) {
  constexpr double kDuration = 10.0;
  std::mt19937 rng(10);
  NavState x;
  x.R = test::random_rotation(rng);  // tilted: gravity is not along a body axis
  x.p = Eigen::Vector3d(1, 2, 3);
  x.bg = Eigen::Vector3d(0.01, -0.02, 0.005);
  x.ba = Eigen::Vector3d(0.1, 0.05, -0.2);
  const NavState x0 = x;
  const Eigen::Vector3d accel = x.R.transpose() * (-x.g) + x.ba;
  const Eigen::Vector3d gyro = x.bg;
  for (int k = 0; k < static_cast<int>(kDuration * kImuRate); ++k) propagate(x, nullptr, gyro, accel, kDt, zero_noise());
  EXPECT_LT((x.p - x0.p).norm(), 1e-9);
  EXPECT_LT(x.v.norm(), 1e-10);
  EXPECT_LT(test::rotation_error(x.R, x0.R), 1e-12);
}

// (b) Constant body rate ω: R(t) = R0·Exp(ω t) (closed form), about a tilted axis.
TEST(Propagation, ConstantRateMatchesClosedFormAttitude) {
  constexpr double kDuration = 5.0;
  const Eigen::Vector3d omega = 0.8 * Eigen::Vector3d(1, -2, 0.5).normalized();
  const Eigen::Vector3d bg(0.003, 0.001, -0.002);
  std::mt19937 rng(11);
  NavState x;
  x.R = test::random_rotation(rng);
  x.bg = bg;
  const Eigen::Matrix3d R0 = x.R;
  const int steps = static_cast<int>(kDuration * kImuRate);
  for (int k = 0; k < steps; ++k) {
    propagate(x, nullptr, omega + bg, x.R.transpose() * (-x.g), kDt, zero_noise());
  }
  const Eigen::Matrix3d R_true = R0 * so3::Exp(omega * steps * kDt);
  EXPECT_LT(test::rotation_error(x.R, R_true), 1e-10);
}

// (c) Constant world acceleration a_W while rotating at a constant rate: the body measures
// f(t) = R(t)ᵀ(a_W − g) with R(t) = R0·Exp(ω t); then p(t) = p0 + v0 t + ½ a_W t², v = v0 + a_W t.
// propagate() holds the sample of the step start over the step, which is exact for this motion.
TEST(Propagation, ConstantWorldAccelerationWhileRotating) {
  constexpr double kDuration = 10.0;
  constexpr double kPositionTol = 1e-6;  // m over ~60 m travelled: round-off only
  const Eigen::Vector3d a_W(0.5, -0.3, 0.2);
  const Eigen::Vector3d omega(0.2, 0.1, -0.4);
  NavState x;
  x.p = Eigen::Vector3d(1, 1, 1);
  x.v = Eigen::Vector3d(1, 0, 0);
  const NavState x0 = x;
  const int steps = static_cast<int>(kDuration * kImuRate);
  for (int k = 0; k < steps; ++k) {
    const Eigen::Matrix3d R_t = x0.R * so3::Exp(omega * k * kDt);
    propagate(x, nullptr, omega, R_t.transpose() * (a_W - x.g), kDt, zero_noise());
  }
  const double T = steps * kDt;
  EXPECT_LT((x.p - (x0.p + x0.v * T + 0.5 * a_W * T * T)).norm(), kPositionTol);
  EXPECT_LT((x.v - (x0.v + a_W * T)).norm(), kPositionTol);
  EXPECT_LT(test::rotation_error(x.R, x0.R * so3::Exp(omega * T)), 1e-10);
}

// The error state of a propagated state: f(x ⊞ δ) ⊟ f(x).
StateVector propagated_difference(const NavState& x, const StateVector& delta, const Eigen::Vector3d& gyro,
                                  const Eigen::Vector3d& accel, double dt) {
  NavState a = x.boxplus(delta), b = x;
  propagate(a, nullptr, gyro, accel, dt, zero_noise());
  propagate(b, nullptr, gyro, accel, dt, zero_noise());
  return a.boxminus(b);
}

/// Numeric F: column i = (f(x ⊞ εe_i) ⊟ f(x) − f(x ⊞ −εe_i) ⊟ f(x)) / 2ε.
StateCovariance numeric_F(const NavState& x, const Eigen::Vector3d& gyro, const Eigen::Vector3d& accel, double dt) {
  constexpr double kEps = 1e-6;
  StateCovariance F;
  for (int i = 0; i < kStateDim; ++i) {
    const StateVector e = kEps * StateVector::Unit(i);
    F.col(i) = (propagated_difference(x, e, gyro, accel, dt) - propagated_difference(x, -e, gyro, accel, dt)) / (2 * kEps);
  }
  return F;
}

// F of the covariance propagation vs numeric differentiation of propagate() with boxplus/boxminus.
// With zero noise and P = e_i e_iᵀ the propagated P is f_i f_iᵀ (f_i = F e_i): compare f_i up to
// sign; then P' = F P Fᵀ for a dense random P fixes the relative signs. The implementation drops
// the ½·dt² terms of δp' (∂p'/∂δθ, ∂p'/∂δb_a, ∂p'/∂δg), so the tolerance is (|a| + |g|)·dt².
TEST(Propagation, CovarianceJacobianMatchesNumericDifferentiation) {
  constexpr double kStep = 1e-3;
  std::mt19937 rng(12);
  for (int trial = 0; trial < 5; ++trial) {
    const NavState x = test::random_state(rng);
    const Eigen::Vector3d gyro = test::random_vector(rng, 1.0), accel = test::random_vector(rng, 5.0);
    const StateCovariance F_num = numeric_F(x, gyro, accel, kStep);
    const double tol = ((accel - x.ba).norm() + kGravity) * kStep * kStep + 1e-7;
    for (int i = 0; i < kStateDim; ++i) {
      StateCovariance P = StateCovariance::Zero();
      P(i, i) = 1.0;
      NavState xi = x;
      propagate(xi, &P, gyro, accel, kStep, zero_noise());
      Eigen::Index k;
      P.diagonal().maxCoeff(&k);
      StateVector f = P.col(k) / std::sqrt(P(k, k));
      if (f.dot(F_num.col(i)) < 0) f = -f;
      EXPECT_LT((f - F_num.col(i)).cwiseAbs().maxCoeff(), tol) << "column " << i << "\nF e_i: " << f.transpose()
                                                               << "\nnumeric: " << F_num.col(i).transpose();
    }
    const StateCovariance P0 = test::random_covariance(rng, 1.0);
    StateCovariance P = P0;
    NavState xp = x;
    propagate(xp, &P, gyro, accel, kStep, zero_noise());
    EXPECT_LT((P - F_num * P0 * F_num.transpose()).cwiseAbs().maxCoeff(), 4 * tol);
  }
}

// The time offset's column. Samples placed δ too late are read as the signal at t − δ: the state
// propagated over a window from the same start with the readings of the signal at t + ε (the
// truth when the offset is ε larger) differs in attitude from the one with the readings at t by
// ε times the column that the propagated covariance carries for t_d (P = e_td e_tdᵀ gives
// P(:, td) = Φ e_td). Only the gyro's part is modelled: the velocity's column stays 0 by design.
TEST(Propagation, TimeOffsetColumnMatchesShiftedReadings) {
  constexpr int kSteps = 40;  // 0.2 s at 200 Hz: two scan periods
  constexpr double kEps = 1e-5;
  const auto gyro_at = [](double t) {
    return Eigen::Vector3d(1.5 * std::sin(3.0 * t), 0.8 * std::cos(2.0 * t), 2.0 * t * t);
  };
  const Eigen::Vector3d accel(0.5, 9.81, -0.3);  // constant: the shift moves only the attitude
  std::mt19937 rng(19);
  for (int trial = 0; trial < 3; ++trial) {
    const NavState x0 = test::random_state(rng);
    const double t0 = 0.3 * trial;
    const auto run = [&](double shift, StateCovariance* P) {
      NavState x = x0;
      for (int k = 0; k < kSteps; ++k) {
        const double ta = t0 + k * kDt + shift, tb = ta + kDt;
        propagate(x, P, 0.5 * (gyro_at(ta) + gyro_at(tb)), accel, kDt, zero_noise(),
                  ReadingChange{gyro_at(tb) - gyro_at(ta)});
      }
      return x;
    };
    StateCovariance P = StateCovariance::Zero();
    P(Idx::kTimeOffset, Idx::kTimeOffset) = 1.0;
    const NavState x = run(0.0, &P);
    const StateVector numeric = (run(kEps, nullptr).boxminus(x) - run(-kEps, nullptr).boxminus(x)) / (2 * kEps);
    const StateVector column = P.col(Idx::kTimeOffset);
    const Eigen::Vector3d rot_num = numeric.segment<3>(Idx::kRot), rot = column.segment<3>(Idx::kRot);
    ASSERT_GT(rot_num.norm(), 0.1);  // the window excites the offset
    EXPECT_LT((rot - rot_num).norm(), 0.02 * rot_num.norm()) << "column:  " << rot.transpose()
                                                             << "\nnumeric: " << rot_num.transpose();
    EXPECT_DOUBLE_EQ(column(Idx::kTimeOffset), 1.0);
  }
}

ImuNoiseConfig monte_carlo_noise() {
  ImuNoiseConfig n;  // ~10× a MEMS IMU so the noise terms matter against the initial covariance
  n.gyro_noise_density = 2e-3;
  n.accel_noise_density = 2e-2;
  n.gyro_bias_random_walk = 2e-4;
  n.accel_bias_random_walk = 5e-3;
  return n;
}

/// One Monte-Carlo sample: x̂ ⊞ δx0 propagated with noisy measurements (white noise of density σ
/// sampled at rate 1/dt has variance σ²/dt) and bias random walks (variance σ²·dt per step).
StateVector monte_carlo_sample(const NavState& x_hat, const Eigen::Matrix<double, kStateDim, kStateDim>& L0,
                               const std::vector<Eigen::Vector3d>& gyro, const std::vector<Eigen::Vector3d>& accel,
                               const NavState& x_end, const ImuNoiseConfig& n, std::mt19937& rng) {
  std::normal_distribution<double> unit(0.0, 1.0);
  StateVector z;
  for (int i = 0; i < kStateDim; ++i) z(i) = unit(rng);
  NavState x = x_hat.boxplus(L0 * z);
  for (std::size_t k = 0; k < gyro.size(); ++k) {
    const Eigen::Vector3d ng = test::random_vector(rng, n.gyro_noise_density / std::sqrt(kDt));
    const Eigen::Vector3d na = test::random_vector(rng, n.accel_noise_density / std::sqrt(kDt));
    propagate(x, nullptr, gyro[k] + ng, accel[k] + na, kDt, n);
    x.bg += test::random_vector(rng, n.gyro_bias_random_walk * std::sqrt(kDt));
    x.ba += test::random_vector(rng, n.accel_bias_random_walk * std::sqrt(kDt));
  }
  return x.boxminus(x_end);
}

// (d) P' = F P Fᵀ + G Q Gᵀ over 1 s of motion agrees with the sample covariance of propagate()
// driven by sampled noise: |S_ij − P_ij| ≤ 5·sqrt((P_ii P_jj + P_ij²)/N) (the standard deviation
// of a Gaussian sample covariance entry); P stays symmetric positive semi-definite.
TEST(Propagation, CovarianceMatchesMonteCarlo) {
  constexpr int kRuns = 4000;
  constexpr int kSteps = static_cast<int>(kImuRate);  // 1 s
  constexpr double kSigmas = 5.0;
  std::mt19937 rng(13);
  const ImuNoiseConfig noise = monte_carlo_noise();
  NavState x_hat = test::random_state(rng);
  StateCovariance P0 = StateCovariance::Zero();
  const StateVector std0 = (StateVector() << 0.02, 0.02, 0.02, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01, 0.01,
                            0.01, 0.05, 0.05, 0.05, 2e-3, 2e-3, 2e-3, 0.05, 0.05, 0.05, 0.01, 0.01)
                               .finished();
  P0.diagonal() = std0.cwiseProduct(std0);
  std::vector<Eigen::Vector3d> gyro, accel;
  for (int k = 0; k < kSteps; ++k) {
    gyro.push_back(Eigen::Vector3d(0.3 * std::sin(2.0 * k * kDt), 0.2, -0.4));
    accel.push_back(x_hat.R.transpose() * (-x_hat.g) + Eigen::Vector3d(1.0, 0.5 * std::cos(3.0 * k * kDt), 0.0));
  }
  NavState x_end = x_hat;
  StateCovariance P = P0;
  for (int k = 0; k < kSteps; ++k) propagate(x_end, &P, gyro[k], accel[k], kDt, noise);

  const StateCovariance L0 = P0.llt().matrixL();
  StateCovariance S = StateCovariance::Zero();
  for (int r = 0; r < kRuns; ++r) {
    const StateVector d = monte_carlo_sample(x_hat, L0, gyro, accel, x_end, noise, rng);
    S += d * d.transpose();
  }
  S /= kRuns;
  for (int i = 0; i < kStateDim; ++i) {
    for (int j = 0; j <= i; ++j) {
      const double sd = std::sqrt((P(i, i) * P(j, j) + P(i, j) * P(i, j)) / kRuns);
      EXPECT_LE(std::abs(S(i, j) - P(i, j)), kSigmas * sd) << "entry (" << i << ", " << j << "): MC " << S(i, j)
                                                           << " vs P " << P(i, j);
    }
  }
  EXPECT_EQ(P, P.transpose());
  const double min_eig = Eigen::SelfAdjointEigenSolver<StateCovariance>(P).eigenvalues().minCoeff();
  EXPECT_GE(min_eig, -1e-12 * P.diagonal().maxCoeff());
}

// The ablation switch: propagate_covariance = false replaces F·P·Fᵀ + Q by a fixed prior, the
// same after every step whatever came before (the state still moves): the configured diagonal
// carried over one scan interval, so position and velocity are coupled by T·σ_v².
TEST(Propagation, CovarianceSwitchOffGivesTheFixedPrior) {
  std::mt19937 rng(14);
  ImuNoiseConfig noise;
  noise.propagate_covariance = false;
  NavState x = test::random_state(rng);
  const NavState x0 = x;
  StateCovariance P = test::random_covariance(rng, 0.1);
  propagate(x, &P, Eigen::Vector3d(0.1, 0.2, 0.3), Eigen::Vector3d(1, 2, 3), kDt, noise);
  const StateCovariance first = P;
  P = test::random_covariance(rng, 0.5);  // whatever the posterior was
  propagate(x, &P, Eigen::Vector3d(0.1, 0.2, 0.3), Eigen::Vector3d(1, 2, 3), kDt, noise);
  const double T = noise.fixed_prior_interval, sv = noise.fixed_velocity_std, sp = noise.fixed_position_std;
  EXPECT_NEAR(P(Idx::kPos, Idx::kPos), sp * sp + sv * sv * T * T, 1e-12);
  EXPECT_NEAR(P(Idx::kPos, Idx::kVel), sv * sv * T, 1e-12);
  EXPECT_NEAR(P(Idx::kVel, Idx::kVel), first(Idx::kVel, Idx::kVel), 1e-3 * first(Idx::kVel, Idx::kVel));
  EXPECT_GT((x.p - x0.p).norm(), 1e-4);
  const double min_eig = Eigen::SelfAdjointEigenSolver<StateCovariance>(P).eigenvalues().minCoeff();
  EXPECT_GE(min_eig, -1e-12);
}

// Noise densities from config: unknown keys and negative densities are refused.
TEST(Propagation, NoiseConfigValidation) {
  ImuNoiseConfig n;
  ConfigNode ok = ConfigNode::from_string("gyro_noise_density: 2.0e-4\npropagate_covariance: false\n");
  n.load(ok);
  EXPECT_DOUBLE_EQ(n.gyro_noise_density, 2.0e-4);
  EXPECT_FALSE(n.propagate_covariance);
  ConfigNode negative = ConfigNode::from_string("accel_noise_density: -1\n");
  EXPECT_THROW(n.load(negative), ConfigError);
  ConfigNode unknown = ConfigNode::from_string("gyro_noise: 1\n");
  EXPECT_THROW(n.load(unknown), ConfigError);
}

}  // namespace
}  // namespace fuse

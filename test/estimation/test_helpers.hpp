// Shared helpers of the estimation tests: random states and rotations with fixed seeds, and a
// sensor at rest.
#pragma once

#include <Eigen/Core>
#include <random>

#include "fuse/core/so3.hpp"
#include "fuse/estimation/state.hpp"
#include "fuse/estimation/state_history.hpp"

namespace fuse::test {

inline Eigen::Vector3d random_vector(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> n(0.0, sigma);
  return Eigen::Vector3d(n(rng), n(rng), n(rng));
}

inline Eigen::Matrix3d random_rotation(std::mt19937& rng) {
  std::uniform_real_distribution<double> angle(0.1, 3.0);
  return so3::Exp(angle(rng) * random_vector(rng, 1.0).normalized());
}

/// A state with every block away from its default (gravity tilted, |g| = 9.81).
inline NavState random_state(std::mt19937& rng) {
  NavState x;
  x.p = random_vector(rng, 5.0);
  x.R = random_rotation(rng);
  x.R_IL = random_rotation(rng);
  x.p_IL = random_vector(rng, 0.3);
  x.td = random_vector(rng, 0.02).x();
  x.v = random_vector(rng, 2.0);
  x.bg = random_vector(rng, 0.01);
  x.ba = random_vector(rng, 0.1);
  x.g = 9.81 * (Eigen::Vector3d(0, 0, -1) + random_vector(rng, 0.2)).normalized();
  return x;
}

/// A random error-state vector with rotations well inside (−π, π).
inline StateVector random_tangent(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> n(0.0, sigma);
  StateVector dx;
  for (int i = 0; i < kStateDim; ++i) dx(i) = n(rng);
  return dx;
}

/// A random symmetric positive definite covariance with standard deviations around `sigma`.
inline StateCovariance random_covariance(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> n(0.0, 1.0);
  StateCovariance A;
  for (int r = 0; r < kStateDim; ++r) {
    for (int c = 0; c < kStateDim; ++c) A(r, c) = n(rng);
  }
  return sigma * sigma * (A * A.transpose() / kStateDim + 0.1 * StateCovariance::Identity());
}

/// Rotation angle between two rotation matrices (rad).
inline double rotation_error(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  return so3::Log(A.transpose() * B).norm();
}

/// The IMU reading of a level sensor at rest at time t (gravity along −z, no bias).
inline ImuSample at_rest(double t = 0.0) {
  ImuSample s;
  s.t = t;
  s.accel = Eigen::Vector3d(0, 0, 9.81);
  return s;
}

/// A history started at 0 at rest at the origin (σ 1 mm / 1 mrad), with an entry at `first_scan`
/// for the scan that seeds the map.
inline StateHistory rested_history(const StateHistoryConfig& history, const ImuNoiseConfig& imu, double first_scan) {
  StateHistory h(history, imu);
  h.reset(0.0, NavState{}, StateCovariance::Identity() * 1e-6, at_rest());
  h.ensure_entry(first_scan);
  return h;
}

}  // namespace fuse::test

// Temporal side of the estimator (DESIGN §1, D_in for IMU and Φ_k): checks each IMU sample,
// runs static initialisation, then propagates into the StateHistory. The single-process
// Estimator and the fuse-state service both own one.
#pragma once

#include "fuse/core/counters.hpp"
#include "fuse/core/types.hpp"
#include "fuse/estimation/estimator_config.hpp"
#include "fuse/estimation/state_history.hpp"
#include "fuse/estimation/static_initializer.hpp"

namespace fuse {

/// The rotation rate assumed across a data gap from the (bias-free) rates w0 before (the mean over
/// a window) and w1 after it, per axis: the one of smaller magnitude when both have the same
/// sign, else zero (minmod).
Eigen::Vector3d agreed_rate(const Eigen::Vector3d& w0, const Eigen::Vector3d& w1);

/// Gravity-direction update from one accelerometer sample: the bias-free specific force f (IMU
/// frame) of a sensor that is not accelerating points up, f/|f| = R_WIᵀu with u = −g/|g|. An
/// iterated EKF update of (x, P) with that measurement and noise σ² I₃ (σ in rad; σ_a/|g| for an
/// unmodelled acceleration σ_a) corrects roll and pitch (and what correlates with them); the
/// heading is unobservable from it and stays.
void level_with_accelerometer(const Eigen::Vector3d& f, double sigma, NavState& x, StateCovariance& P);

class StateTracker {
 public:
  explicit StateTracker(const EstimatorConfig& config);

  /// D_in: refuses non-finite or non-increasing samples (counted), flags gaps, initialises from
  /// a static start, then propagates.
  void ingest(const ImuSample& imu);
  /// Starts the history from a posterior held elsewhere (a restarted fuse-state recovering the
  /// last correction); `held` is the IMU measurement in force at t.
  void restore(double t, const NavState& x, const StateCovariance& P, const ImuSample& held);

  bool initialised() const { return history_.initialised(); }
  StateHistory& history() { return history_; }
  const StateHistory& history() const { return history_; }
  double last_imu_time() const { return last_imu_t_; }
  Counters& counters() { return counters_; }
  const Counters& counters() const { return counters_; }

 private:
  void initialise(const NavState& x0, const ImuSample& imu);
  /// Propagates across a data gap up to the sample after it (constant velocity, agreed_rate).
  void coast_across_gap(const ImuSample& imu);
  /// Covariance of the motion nobody measured during a data gap of dt seconds.
  StateCovariance gap_noise(double dt) const;

  EstimatorConfig config_;
  StaticInitializer initializer_;
  StateHistory history_;
  double last_imu_t_ = -1.0;
  Counters counters_;
};

}  // namespace fuse

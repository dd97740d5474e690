// How well the recent motion excites the LiDAR-IMU extrinsic (estimator.extrinsic_excitation).
// The extrinsic is observable only through rotation: a lever arm shows as the LiDAR moving on an
// arc when the body turns, and a rotation error as points that move wrongly when it turns about
// another axis. A vehicle on a road turns about its vertical axis only, so its roll and pitch
// carry no information about the extrinsic, and an estimate left free there follows noise and
// map errors instead. The monitor measures the body rates over a window of scan-end attitudes,
//   ω_k = Log(R_{k−1}ᵀ R_k) / (t_k − t_{k−1})        (body frame),
//   M = mean over the window of ω_k ω_kᵀ,
// and calls the motion exciting when even the weakest axis turns at min_rate_deg_s RMS or more:
// √λ_min(M) ≥ min_rate. Below it the extrinsic is held (its rows and columns left out of the
// update) rather than estimated. A turn about one axis a (√λ_max ≥ min_rate, the eigenvector
// of λ_max) still shows the LiDAR's tilt against a, R_IL·b = a for the LiDAR's own turn axis b
// (hand-eye calibration), but not the rotation about a nor a lever arm along a. With one_axis
// "tilt" the rotation about a is held, and the whole translation (a lever arm across a is seen
// too, but left free on the urban and campus drives it moved up to 4 cm further from the truth).
#pragma once

#include <Eigen/Core>
#include <deque>

#include "fuse/core/config.hpp"

namespace fuse {

struct ExcitationConfig {
  double window_s = 5.0;        ///< s of scan-end attitudes the rates are taken over
  double min_rate_deg_s = 3.0;  ///< °/s RMS the weakest axis must turn at for the extrinsic to be estimated
  /// While the motion turns about one axis a only (its strongest axis at min_rate or more, its
  /// weakest below): "tilt" estimates the extrinsic's rotation about the two axes normal to a
  /// (the LiDAR's tilt against it, which a turn about a shows) and holds its rotation about a
  /// and its translation; "hold" holds all of it.
  enum class OneAxis { kTilt, kHold } one_axis = OneAxis::kTilt;
  void load(ConfigNode& node);
};

class ExcitationMonitor {
 public:
  explicit ExcitationMonitor(const ExcitationConfig& config) : config_(config) {}
  /// The posterior attitude R_WI at a scan end t (times increasing; an older t restarts).
  void add(double t, const Eigen::Matrix3d& R_WI);
  /// RMS rate about the least excited axis over the window, rad/s (0 until the window holds a rate).
  double weakest_rate() const;
  /// Whether the window spans at least half of window_s and its weakest rate reaches min_rate.
  bool excited() const;
  /// Whether the window spans at least half of window_s and its strongest axis turns at min_rate
  /// or more; then `axis` is that axis (body frame, unit).
  bool turns_about(Eigen::Vector3d& axis) const;
  void reset() { rates_.clear(), have_last_ = false; }

 private:
  Eigen::Matrix3d moment() const;  ///< M over the window (rates_ not empty)
  struct Rate {
    double t;
    Eigen::Vector3d w;
  };
  ExcitationConfig config_;
  std::deque<Rate> rates_;
  bool have_last_ = false;
  double last_t_ = 0.0;
  Eigen::Matrix3d last_R_ = Eigen::Matrix3d::Identity();
};

}  // namespace fuse

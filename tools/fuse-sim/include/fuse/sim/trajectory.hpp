// The true motion of the IMU frame: a smooth path c(u) walked with the time law u(t), plus
// handheld / vehicle oscillations (bob, sway, roll, pitch, yaw) whose amplitude scales with the
// current speed, so the body is exactly at rest whenever u' = 0. The attitude is
// R_WI = Rz(yaw) Ry(pitch) Rx(roll) with yaw = path heading + oscillation. A vehicle may add
// suspension pitch and roll that follow its own acceleration (suspension.hpp; the body turns about
// the IMU). Everything is evaluated with Jets, so velocity, acceleration and angular velocity are
// exact derivatives.
#pragma once

#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "fuse/sim/jet.hpp"
#include "fuse/sim/path.hpp"
#include "fuse/sim/suspension.hpp"
#include "fuse/sim/time_law.hpp"

namespace fuse::sim {

/// One sinusoid a * sin(2 pi f t + phase), t in seconds since the trajectory start.
struct Oscillation {
  double amplitude = 0.0;  ///< metres or radians
  double frequency_hz = 1.0;
  double phase = 0.0;  ///< radians
};

/// Oscillations scaled by the speed envelope u'/rate; lateral is along the path's left normal.
struct MotionConfig {
  std::vector<Oscillation> lateral, vertical, roll, pitch, yaw;
  double pitch_offset = 0.0;  ///< constant attitude offsets (radians)
  double roll_offset = 0.0;
  SuspensionConfig suspension;  ///< enabled: pitch and roll follow the path acceleration (a car)
};

/// The exact state at one instant (IMU frame in the world frame).
struct TrajectoryState {
  double t = 0.0;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();      ///< position of the IMU in W
  Eigen::Vector3d v = Eigen::Vector3d::Zero();      ///< dp/dt in W
  Eigen::Vector3d a = Eigen::Vector3d::Zero();      ///< d2p/dt2 in W
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  ///< R_WI
  Eigen::Vector3d omega_body = Eigen::Vector3d::Zero();  ///< angular velocity in I (R^T dR/dt)^v
};

class Trajectory {
 public:
  Trajectory(Path path, const TimeLawConfig& time_law, const MotionConfig& motion, double t0);

  TrajectoryState state(double t) const;  ///< t in absolute seconds; clamped to [t_begin, t_end]
  double t_begin() const { return t0_; }
  double t_end() const { return t0_ + time_law_.duration(); }
  const Path& path() const { return path_; }
  const TimeLaw& time_law() const { return time_law_; }
  const MotionConfig& motion() const { return motion_; }

 private:
  Path path_;
  TimeLaw time_law_;
  MotionConfig motion_;
  double t0_;
  std::optional<SuspensionResponse> suspension_;
};

}  // namespace fuse::sim

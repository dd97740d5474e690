#include "fuse/estimation/static_initializer.hpp"

#include <cmath>

namespace fuse {

void StaticInitConfig::load(ConfigNode& node) {
  node.get("duration_s", duration_s).get("max_gyro_std", max_gyro_std).get("max_accel_std", max_accel_std);
  node.check(duration_s >= 0.05 && duration_s <= 60.0, "duration_s", "must be in [0.05, 60] s");
  node.check(max_gyro_std > 0.0, "max_gyro_std", "must be positive");
  node.check(max_accel_std > 0.0, "max_accel_std", "must be positive");
  node.finish();
}

std::optional<NavState> StaticInitializer::add(const ImuSample& imu, double gravity_magnitude) {
  window_.push_back(imu);
  if (window_.back().t - window_.front().t < config_.duration_s) return std::nullopt;

  Eigen::Vector3d mg = Eigen::Vector3d::Zero(), ma = Eigen::Vector3d::Zero();
  for (const auto& s : window_) {
    mg += s.gyro;
    ma += s.accel;
  }
  const double n = static_cast<double>(window_.size());
  mg /= n;
  ma /= n;
  double vg = 0.0, va = 0.0;
  for (const auto& s : window_) {
    vg += (s.gyro - mg).squaredNorm();
    va += (s.accel - ma).squaredNorm();
  }
  if (std::sqrt(vg / n) > config_.max_gyro_std || std::sqrt(va / n) > config_.max_accel_std) {
    window_.erase(window_.begin(), window_.begin() + static_cast<std::ptrdiff_t>(window_.size() / 2));
    ++restarts_;
    return std::nullopt;
  }
  NavState x;
  x.bg = mg;
  x.g = Eigen::Vector3d(0, 0, -gravity_magnitude);
  // Rotation taking the mean specific force direction to world +z (roll, pitch; yaw = 0).
  x.R = Eigen::Quaterniond::FromTwoVectors(ma.normalized(), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  rest_since_ = window_[window_.size() - 2].t;  // the window spans duration_s > 0: two samples at least
  window_.clear();
  return x;
}

}  // namespace fuse

#include "fuse/estimation/excitation_monitor.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <string>

#include "fuse/core/so3.hpp"

namespace fuse {

namespace {
constexpr double kMaxWindowS = 600.0;
constexpr double kDegToRad = M_PI / 180.0;
}  // namespace

void ExcitationConfig::load(ConfigNode& node) {
  std::string axis = one_axis == OneAxis::kTilt ? "tilt" : "hold";
  node.get("window_s", window_s).get("min_rate_deg_s", min_rate_deg_s).get("one_axis", axis);
  node.check(axis == "tilt" || axis == "hold", "one_axis", "must be tilt or hold");
  one_axis = axis == "tilt" ? OneAxis::kTilt : OneAxis::kHold;
  node.check(std::isfinite(window_s) && window_s > 0.0 && window_s <= kMaxWindowS, "window_s", "must be in (0, 600] s");
  node.check(std::isfinite(min_rate_deg_s) && min_rate_deg_s >= 0.0 && min_rate_deg_s <= 180.0, "min_rate_deg_s",
             "must be in [0, 180] deg/s");
  node.finish();
}

void ExcitationMonitor::add(double t, const Eigen::Matrix3d& R_WI) {
  if (have_last_ && t <= last_t_) {
    if (t < last_t_) reset();  // time went back: start over
    else return;               // the same scan end again
  }
  if (have_last_) rates_.push_back({t, so3::Log(last_R_.transpose() * R_WI) / (t - last_t_)});
  have_last_ = true;
  last_t_ = t;
  last_R_ = R_WI;
  while (!rates_.empty() && rates_.front().t < t - config_.window_s) rates_.pop_front();
}

Eigen::Matrix3d ExcitationMonitor::moment() const {
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  for (const Rate& r : rates_) M += r.w * r.w.transpose();
  return M / static_cast<double>(rates_.size());
}

double ExcitationMonitor::weakest_rate() const {
  if (rates_.empty()) return 0.0;
  const Eigen::Matrix3d M = moment();
  const double lambda_min = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(M, Eigen::EigenvaluesOnly).eigenvalues()(0);
  return std::sqrt(std::max(lambda_min, 0.0));
}

bool ExcitationMonitor::excited() const {
  if (rates_.empty() || last_t_ - rates_.front().t < 0.5 * config_.window_s) return false;
  return weakest_rate() >= config_.min_rate_deg_s * kDegToRad;
}

bool ExcitationMonitor::turns_about(Eigen::Vector3d& axis) const {
  if (rates_.empty() || last_t_ - rates_.front().t < 0.5 * config_.window_s) return false;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(moment());
  if (std::sqrt(std::max(es.eigenvalues()(2), 0.0)) < config_.min_rate_deg_s * kDegToRad) return false;
  axis = es.eigenvectors().col(2).normalized();
  return true;
}

}  // namespace fuse

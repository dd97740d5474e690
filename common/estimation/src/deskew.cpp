#include "fuse/estimation/deskew.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace fuse {

namespace {
/// Below this angle (rad) the Taylor series of Rodrigues' coefficients to θ⁶ are exact to double
/// precision (the first term left out, θ⁸/9!, is 3·10⁻¹⁴ at 0.1 rad). Between two IMU samples a
/// vehicle or a handheld sensor turns by less (0.1 rad in 5 ms is 20 rad/s).
constexpr double kSeriesMaxAngle = 0.1;

/// Exp(φ)·v by Rodrigues' formula on the vector, without forming the matrix:
///   Exp(φ)v = v + a·φ×v + b·φ×(φ×v),  a = sin θ/θ,  b = (1 − cos θ)/θ²,  θ = |φ|.
Eigen::Vector3d rotate_by_exp(const Eigen::Vector3d& phi, const Eigen::Vector3d& v) {
  const double t2 = phi.squaredNorm();
  double a = 0.0;
  double b = 0.0;
  if (t2 < kSeriesMaxAngle * kSeriesMaxAngle) {
    a = 1.0 - t2 / 6.0 * (1.0 - t2 / 20.0 * (1.0 - t2 / 42.0));          // sin θ/θ
    b = 0.5 * (1.0 - t2 / 12.0 * (1.0 - t2 / 30.0 * (1.0 - t2 / 56.0)));  // (1 − cos θ)/θ²
  } else {
    const double t = std::sqrt(t2);
    a = std::sin(t) / t;
    b = (1.0 - std::cos(t)) / t2;
  }
  const Eigen::Vector3d w = phi.cross(v);
  return v + a * w + b * phi.cross(w);
}
}  // namespace

bool Deskewer::prepare(const StateHistory& history, double t_start, double t_end) {
  knots_.clear();
  const StateQuery q_end = history.query(t_end);
  const StateQuery q_start = history.query(t_start);
  if (!q_end.ok() || !q_start.ok()) return false;
  const Eigen::Matrix3d Re_t = q_end.x.R.transpose();
  auto add = [&](double t, const NavState& x) {
    knots_.push_back({t - t_start, Re_t * x.R, Re_t * (x.p - q_end.x.p), Eigen::Vector3d::Zero()});
  };
  add(t_start, q_start.x);
  for (const StateHistory::Entry* e : history.entries_between(t_start, t_end)) {
    if (e->t > t_start && e->t < t_end) add(e->t, e->x);
  }
  add(t_end, q_end.x);
  for (std::size_t k = 0; k + 1 < knots_.size(); ++k) {
    knots_[k].omega = so3::Log(knots_[k].R.transpose() * knots_[k + 1].R);
  }
  return true;
}

void Deskewer::apply(const LidarScan& scan, const std::vector<std::uint32_t>& indices, const Eigen::Isometry3d& T_IL,
                     std::vector<Eigen::Vector3f>& out, std::vector<Eigen::Vector3f>* origins) const {
  out.resize(indices.size());
  if (origins != nullptr) origins->resize(indices.size());
  const Eigen::Matrix3d R_IL = T_IL.linear();
  const Eigen::Vector3d p_IL = T_IL.translation();
  const Eigen::Matrix3d R_LI = R_IL.transpose();
  // Knot k of a point at t: the last with knots_[k].t_rel <= t (at most the second last). The
  // points come in spatial order (LidarUpdater::order_spatially), not in time, so each point
  // starts from the knot of its slice of the scan's span, found once per scan, and steps on from
  // there (a binary search per point was a handful of branches no predictor can learn).
  constexpr std::size_t kSlices = 64;
  const double span = knots_.back().t_rel;
  const double per_slice = span > 0.0 ? static_cast<double>(kSlices) / span : 0.0;
  std::array<std::size_t, kSlices> slice_knot{};  // all 0 when the span is 0
  for (std::size_t j = 0, k = 0; span > 0.0 && j < kSlices; ++j) {
    const double t_j = static_cast<double>(j) / per_slice;  // the slice's start
    while (k + 2 < knots_.size() && knots_[k + 1].t_rel <= t_j) ++k;
    slice_knot[j] = k;
  }
  for (std::size_t i = 0; i < indices.size(); ++i) {
    const LidarPoint& pt = scan.points[indices[i]];
    const double t = std::clamp(static_cast<double>(pt.t_rel), 0.0, span);
    const double slice = t * per_slice;  // in [0, kSlices]; NaN (a point the readers refuse) takes slice 0
    std::size_t k = slice_knot[slice > 0.0 ? std::min(static_cast<std::size_t>(slice), kSlices - 1) : 0];
    while (k > 0 && knots_[k].t_rel > t) --k;  // a slice start rounded past t
    while (k + 2 < knots_.size() && knots_[k + 1].t_rel <= t) ++k;
    const Knot& a = knots_[k];
    const Knot& b = knots_[std::min(k + 1, knots_.size() - 1)];
    const double span = b.t_rel - a.t_rel;
    const double s = span > 0.0 ? (t - a.t_rel) / span : 0.0;
    // R(t) = R_a · Exp(s·ω_a), applied to vectors.
    const Eigen::Vector3d phi = s * a.omega;
    const Eigen::Vector3d p = (1.0 - s) * a.p + s * b.p;
    const Eigen::Vector3d p_I = R_IL * Eigen::Vector3d(pt.x, pt.y, pt.z) + p_IL;
    out[i] = (R_LI * (a.R * rotate_by_exp(phi, p_I) + p - p_IL)).cast<float>();
    if (origins != nullptr) (*origins)[i] = (R_LI * (a.R * rotate_by_exp(phi, p_IL) + p - p_IL)).cast<float>();
  }
}

}  // namespace fuse

#include "fuse/estimation/deskew.hpp"

#include <algorithm>

namespace fuse {

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
  std::size_t k = 0;
  for (std::size_t i = 0; i < indices.size(); ++i) {
    const LidarPoint& pt = scan.points[indices[i]];
    const double t = std::clamp(static_cast<double>(pt.t_rel), 0.0, knots_.back().t_rel);
    // Knot k with knots_[k].t_rel <= t < knots_[k+1].t_rel (points are mostly time-sorted).
    if (k + 1 >= knots_.size() || t < knots_[k].t_rel) k = 0;
    while (k + 2 < knots_.size() && knots_[k + 1].t_rel <= t) ++k;
    const Knot& a = knots_[k];
    const Knot& b = knots_[std::min(k + 1, knots_.size() - 1)];
    const double span = b.t_rel - a.t_rel;
    const double s = span > 0.0 ? (t - a.t_rel) / span : 0.0;
    const Eigen::Matrix3d R = a.R * so3::Exp(s * a.omega);
    const Eigen::Vector3d p = (1.0 - s) * a.p + s * b.p;
    const Eigen::Vector3d p_I = R_IL * Eigen::Vector3d(pt.x, pt.y, pt.z) + p_IL;
    out[i] = (R_LI * (R * p_I + p - p_IL)).cast<float>();
    if (origins != nullptr) (*origins)[i] = (R_LI * (R * p_IL + p - p_IL)).cast<float>();
  }
}

}  // namespace fuse

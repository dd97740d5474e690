#include "fuse/estimation/point_to_plane_model.hpp"

#include <chrono>

namespace fuse {

void PointToPlaneModel::Config::load(ConfigNode& node) {
  node.get("point_sigma", point_sigma).get("reassociate_iterations", reassociate_iterations);
  node.get("weight_by_plane_fit", weight_by_plane_fit);
  node.get("reassociate_translation", reassociate_translation).get("reassociate_rotation", reassociate_rotation);
  node.check(point_sigma > 0.0, "point_sigma", "must be positive");
  node.check(reassociate_iterations >= 1, "reassociate_iterations", "must be >= 1");
  node.check(reassociate_translation >= 0.0, "reassociate_translation", "must be >= 0");
  node.check(reassociate_rotation >= 0.0, "reassociate_rotation", "must be >= 0");
  node.finish();
}

Eigen::Matrix<double, 1, kObsDim> point_to_plane_jacobian(const NavState& x, const Constraint& c) {
  const Eigen::Vector3d n = c.normal.cast<double>();
  const Eigen::Vector3d p_L = c.point.cast<double>();
  const Eigen::Vector3d q = x.R_IL * p_L + x.p_IL;
  const Eigen::Vector3d Rt_n = x.R.transpose() * n;
  Eigen::Matrix<double, 1, kObsDim> H = Eigen::Matrix<double, 1, kObsDim>::Zero();
  H.segment<3>(Idx::kPos) = n.transpose();
  H.segment<3>(Idx::kRot) = q.cross(Rt_n).transpose();
  H.segment<3>(Idx::kExtRot) = p_L.cross(x.R_IL.transpose() * Rt_n).transpose();
  H.segment<3>(Idx::kExtPos) = Rt_n.transpose();
  return H;
}

double point_to_plane_residual(const NavState& x, const Constraint& c) {
  const Eigen::Vector3d q = x.R_IL * c.point.cast<double>() + x.p_IL;
  return c.normal.cast<double>().dot(x.R * q + x.p) + static_cast<double>(c.d);
}

bool PointToPlaneModel::linearize(const NavState& x, int iteration, LinearSystem& out) {
  const Eigen::Isometry3d T_WL = x.T_WI() * x.T_IL();
  const auto t0 = std::chrono::steady_clock::now();
  bool search = !associated_;
  if (associated_ && iteration < config_.reassociate_iterations) {
    const Eigen::Isometry3d delta = T_WL_associated_.inverse() * T_WL;
    search = delta.translation().norm() > config_.reassociate_translation ||
             Eigen::AngleAxisd(delta.linear()).angle() > config_.reassociate_rotation;
  }
  if (search) {
    associator_.associate(points_L_, T_WL, map_, constraints_);
    associated_ = true;
    ++searches_;
    T_WL_associated_ = T_WL;
  } else {
    associator_.rescreen(T_WL, constraints_);
  }
  association_ms_ += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  const double sigma2 = config_.point_sigma * config_.point_sigma;
  // Accumulate only the pose block unless the extrinsic is estimated (6×6 instead of 12×12).
  Eigen::Matrix<double, 6, 6> info6 = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> grad6 = Eigen::Matrix<double, 6, 1>::Zero();
  double lever2 = 0.0;
  out = LinearSystem{};
  for (const Constraint& c : constraints_.constraints) {
    const double rms2 = config_.weight_by_plane_fit ? static_cast<double>(c.plane_rms) * c.plane_rms : 0.0;
    const double w = 1.0 / (sigma2 + rms2);
    const Eigen::Vector3d n = c.normal.cast<double>();
    const Eigen::Vector3d q = x.R_IL * c.point.cast<double>() + x.p_IL;
    const double r = n.dot(x.R * q + x.p) + static_cast<double>(c.d);
    if (config_.extrinsic_jacobian) {
      const Eigen::Matrix<double, 1, kObsDim> H = point_to_plane_jacobian(x, c);
      out.information.noalias() += w * H.transpose() * H;
      out.gradient.noalias() += w * r * H.transpose();
    } else {
      Eigen::Matrix<double, 6, 1> h;
      h.head<3>() = n;
      h.tail<3>() = q.cross(x.R.transpose() * n);
      info6.noalias() += w * h * h.transpose();
      grad6.noalias() += (w * r) * h;
    }
    out.cost += w * r * r;
    lever2 += q.squaredNorm();
  }
  if (!config_.extrinsic_jacobian) {
    out.information.topLeftCorner<6, 6>() = info6;
    out.gradient.head<6>() = grad6;
  }
  out.count = constraints_.constraints.size();
  if (out.count > 0) out.characteristic_length = std::sqrt(lever2 / static_cast<double>(out.count));
  return out.count > 0;
}

}  // namespace fuse

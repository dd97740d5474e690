// The LiDAR-inertial state on its manifold (DESIGN §1):
//   x = (p_WI, R_WI, R_IL, p_IL, t_d, v_WI, b_g, b_a, g ∈ S²)
// and its 24-dimensional error state δx, ordered as the Index constants below. Rotations use
// right perturbations (R = R̂·Exp(δθ)); gravity uses a 2-D tangent basis of the sphere |g| = const.
// t_d is the LiDAR-IMU time offset, t_imu = t_lidar + t_d: the state runs on the IMU's clock, and a
// scan stamped t on the LiDAR's is placed at t + t_d (docs/architecture.md, "Time offset").
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

#include "fuse/core/so3.hpp"

namespace fuse {

inline constexpr int kStateDim = 24;
using StateVector = Eigen::Matrix<double, kStateDim, 1>;
using StateCovariance = Eigen::Matrix<double, kStateDim, kStateDim>;

/// Offsets of each block in the error state.
struct Idx {
  static constexpr int kPos = 0;     ///< δp_WI
  static constexpr int kRot = 3;     ///< δθ_WI
  static constexpr int kExtRot = 6;  ///< δθ_IL
  static constexpr int kExtPos = 9;  ///< δp_IL
  static constexpr int kTimeOffset = 12;  ///< δt_d (s)
  static constexpr int kVel = 13;    ///< δv_WI
  static constexpr int kBg = 16;     ///< δb_g
  static constexpr int kBa = 19;     ///< δb_a
  static constexpr int kGrav = 22;   ///< δg (2-D, tangent of S²)
};

/// Orthonormal 3x2 basis of the plane tangent to the sphere at g (a smooth choice away from ±x).
inline Eigen::Matrix<double, 3, 2> GravityTangentBasis(const Eigen::Vector3d& g) {
  const Eigen::Vector3d u = g.normalized();
  Eigen::Vector3d helper = Eigen::Vector3d::UnitX();
  if (std::abs(u.dot(helper)) > 0.9) helper = Eigen::Vector3d::UnitY();
  Eigen::Matrix<double, 3, 2> B;
  B.col(0) = u.cross(helper).normalized();
  B.col(1) = u.cross(B.col(0));
  return B;
}

struct NavState {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();      ///< p_WI
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  ///< R_WI
  Eigen::Matrix3d R_IL = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p_IL = Eigen::Vector3d::Zero();
  double td = 0.0;                                   ///< s, t_imu = t_lidar + td
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  Eigen::Vector3d bg = Eigen::Vector3d::Zero();
  Eigen::Vector3d ba = Eigen::Vector3d::Zero();
  Eigen::Vector3d g = Eigen::Vector3d(0, 0, -9.81);

  /// x ⊞ δx
  NavState boxplus(const StateVector& dx) const {
    NavState out = *this;
    out.p += dx.segment<3>(Idx::kPos);
    out.R = so3::Normalize(R * so3::Exp(dx.segment<3>(Idx::kRot)));
    out.R_IL = so3::Normalize(R_IL * so3::Exp(dx.segment<3>(Idx::kExtRot)));
    out.p_IL += dx.segment<3>(Idx::kExtPos);
    out.td += dx(Idx::kTimeOffset);
    out.v += dx.segment<3>(Idx::kVel);
    out.bg += dx.segment<3>(Idx::kBg);
    out.ba += dx.segment<3>(Idx::kBa);
    out.g = so3::Exp(GravityTangentBasis(g) * dx.segment<2>(Idx::kGrav)) * g;
    return out;
  }

  /// x ⊟ y: the δx with y ⊞ δx = x.
  StateVector boxminus(const NavState& y) const {
    StateVector dx;
    dx.segment<3>(Idx::kPos) = p - y.p;
    dx.segment<3>(Idx::kRot) = so3::Log(y.R.transpose() * R);
    dx.segment<3>(Idx::kExtRot) = so3::Log(y.R_IL.transpose() * R_IL);
    dx.segment<3>(Idx::kExtPos) = p_IL - y.p_IL;
    dx(Idx::kTimeOffset) = td - y.td;
    dx.segment<3>(Idx::kVel) = v - y.v;
    dx.segment<3>(Idx::kBg) = bg - y.bg;
    dx.segment<3>(Idx::kBa) = ba - y.ba;
    // Rotation taking y.g to g, expressed in y's tangent basis.
    const Eigen::Vector3d a = y.g.normalized(), b = g.normalized();
    const Eigen::Vector3d axis = a.cross(b);
    const double s = axis.norm(), c = a.dot(b);
    const Eigen::Vector3d rotvec = s < 1e-12 ? Eigen::Vector3d::Zero() : Eigen::Vector3d(axis / s * std::atan2(s, c));
    dx.segment<2>(Idx::kGrav) = GravityTangentBasis(y.g).transpose() * rotvec;
    return dx;
  }

  Eigen::Isometry3d T_WI() const {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R;
    T.translation() = p;
    return T;
  }
  Eigen::Isometry3d T_IL() const {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = R_IL;
    T.translation() = p_IL;
    return T;
  }
  bool all_finite() const {
    return p.allFinite() && R.allFinite() && R_IL.allFinite() && p_IL.allFinite() && std::isfinite(td) && v.allFinite() &&
           bg.allFinite() && ba.allFinite() && g.allFinite();
  }
};

}  // namespace fuse

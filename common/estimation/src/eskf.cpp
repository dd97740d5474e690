#include "fuse/estimation/eskf.hpp"

#include "fuse/estimation/ekf.hpp"

namespace fuse {

StateCovariance eskf_reset_jacobian(const NavState& prior, const StateVector& delta) {
  StateCovariance G = StateCovariance::Identity();
  for (int block : {Idx::kRot, Idx::kExtRot}) {
    G.block<3, 3>(block, block) -= 0.5 * so3::hat(Eigen::Vector3d(delta.segment<3>(block)));
  }
  const Eigen::Matrix<double, 3, 2> B = GravityTangentBasis(prior.g);
  const Eigen::Vector3d phi = B * delta.segment<2>(Idx::kGrav);
  const Eigen::Vector3d g_post = so3::Exp(phi) * prior.g;
  const Eigen::Matrix3d J_left = Eigen::Matrix3d::Identity() + 0.5 * so3::hat(phi);
  G.block<2, 2>(Idx::kGrav, Idx::kGrav) = GravityTangentBasis(g_post).transpose() * J_left * B;
  return G;
}

UpdateResult EskfBackend::update(NavState& x, StateCovariance& P, MeasurementModel& model) {
  UpdateResult result;
  const NavState prior = x;
  const StateVector delta = kalman_step(x, P, model, config_.degeneracy, result);
  if (!result.updated) return result;
  const StateCovariance G = eskf_reset_jacobian(prior, delta);
  const StateCovariance P_reset = G * P * G.transpose();
  P = 0.5 * (P_reset + P_reset.transpose());
  return result;
}

}  // namespace fuse

#include "fuse/estimation/imu_propagation.hpp"

namespace fuse {

void ImuNoiseConfig::load(ConfigNode& node) {
  node.get("gyro_noise_density", gyro_noise_density)
      .get("accel_noise_density", accel_noise_density)
      .get("gyro_bias_random_walk", gyro_bias_random_walk)
      .get("accel_bias_random_walk", accel_bias_random_walk)
      .get("inflation", inflation)
      .get("propagate_covariance", propagate_covariance);
  for (const auto& [key, value] :
       {std::pair<const char*, double>{"gyro_noise_density", gyro_noise_density},
        {"accel_noise_density", accel_noise_density},
        {"gyro_bias_random_walk", gyro_bias_random_walk},
        {"accel_bias_random_walk", accel_bias_random_walk}}) {
    node.check(std::isfinite(value) && value >= 0.0, key, "must be a finite non-negative density");
  }
  node.check(std::isfinite(inflation) && inflation > 0.0, "inflation", "must be positive");
  node.finish();
}

void propagate(NavState& x, StateCovariance* P, const Eigen::Vector3d& gyro, const Eigen::Vector3d& accel,
               double dt, const ImuNoiseConfig& noise) {
  const Eigen::Vector3d w = gyro - x.bg;
  const Eigen::Vector3d a = accel - x.ba;
  const Eigen::Vector3d wdt = w * dt;
  const Eigen::Matrix3d dR = so3::Exp(wdt);
  const Eigen::Vector3d a_W = x.R * a + x.g;

  if (P != nullptr && noise.propagate_covariance) {
    // Error-state transition F = I + (∂δx'/∂δx − I); only the non-identity blocks are filled.
    StateCovariance F = StateCovariance::Identity();
    const Eigen::Matrix3d Jr = so3::RightJacobian(wdt);
    F.block<3, 3>(Idx::kPos, Idx::kVel) = Eigen::Matrix3d::Identity() * dt;          // δp' = δp + δv·dt
    F.block<3, 3>(Idx::kRot, Idx::kRot) = dR.transpose();                             // δθ' = Exp(−ωdt)·δθ
    F.block<3, 3>(Idx::kRot, Idx::kBg) = -Jr * dt;                                    //       − J_r(ωdt)·dt·δb_g
    F.block<3, 3>(Idx::kVel, Idx::kRot) = -x.R * so3::hat(a) * dt;                    // δv' = δv − R[a]×dt·δθ
    F.block<3, 3>(Idx::kVel, Idx::kBa) = -x.R * dt;                                   //       − R·dt·δb_a
    F.block<3, 2>(Idx::kVel, Idx::kGrav) = -so3::hat(x.g) * GravityTangentBasis(x.g) * dt;  // + ∂g/∂δg·dt
    // Discrete noise: white noise of density σ integrated over dt has variance σ²·dt.
    const double s2 = noise.inflation * noise.inflation;
    const double qg = s2 * noise.gyro_noise_density * noise.gyro_noise_density * dt;
    const double qa = s2 * noise.accel_noise_density * noise.accel_noise_density * dt;
    const double qbg = s2 * noise.gyro_bias_random_walk * noise.gyro_bias_random_walk * dt;
    const double qba = s2 * noise.accel_bias_random_walk * noise.accel_bias_random_walk * dt;
    StateCovariance& cov = *P;
    cov = F * cov * F.transpose();
    cov.block<3, 3>(Idx::kRot, Idx::kRot) += qg * Jr * Jr.transpose();
    cov.block<3, 3>(Idx::kVel, Idx::kVel) += qa * Eigen::Matrix3d::Identity();
    cov.block<3, 3>(Idx::kBg, Idx::kBg) += qbg * Eigen::Matrix3d::Identity();
    cov.block<3, 3>(Idx::kBa, Idx::kBa) += qba * Eigen::Matrix3d::Identity();
    cov = 0.5 * (cov + cov.transpose()).eval();
  }

  x.p += x.v * dt + 0.5 * a_W * dt * dt;
  x.v += a_W * dt;
  x.R = so3::Normalize(x.R * dR);
}

}  // namespace fuse

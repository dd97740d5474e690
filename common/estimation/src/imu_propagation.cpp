#include "fuse/estimation/imu_propagation.hpp"

namespace fuse {

void ImuNoiseConfig::load(ConfigNode& node) {
  node.get("gyro_noise_density", gyro_noise_density)
      .get("accel_noise_density", accel_noise_density)
      .get("gyro_bias_random_walk", gyro_bias_random_walk)
      .get("accel_bias_random_walk", accel_bias_random_walk)
      .get("inflation", inflation)
      .get("propagate_covariance", propagate_covariance)
      .get("fixed_position_std", fixed_position_std)
      .get("fixed_rotation_std", fixed_rotation_std)
      .get("fixed_velocity_std", fixed_velocity_std)
      .get("fixed_gyro_bias_std", fixed_gyro_bias_std)
      .get("fixed_accel_bias_std", fixed_accel_bias_std)
      .get("fixed_prior_interval", fixed_prior_interval);
  node.check(std::isfinite(fixed_prior_interval) && fixed_prior_interval > 0.0 && fixed_prior_interval <= 1.0,
             "fixed_prior_interval", "must be in (0, 1] s");
  for (const auto& [key, value] : {std::pair<const char*, double>{"fixed_position_std", fixed_position_std},
                                   {"fixed_rotation_std", fixed_rotation_std},
                                   {"fixed_velocity_std", fixed_velocity_std},
                                   {"fixed_gyro_bias_std", fixed_gyro_bias_std},
                                   {"fixed_accel_bias_std", fixed_accel_bias_std}}) {
    node.check(std::isfinite(value) && value > 0.0, key, "must be a positive finite standard deviation");
  }
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
               double dt, const ImuNoiseConfig& noise, const ReadingChange& change) {
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
    F.block<3, 1>(Idx::kRot, Idx::kTimeOffset) = Jr * change.gyro;                    // + J_r·Δω·δt_d
    // (The velocity's R·Δf·δt_d is left out: imu_propagation.hpp, ReadingChange.)
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
    cov(Idx::kTimeOffset, Idx::kTimeOffset) += noise.time_offset_random_walk * noise.time_offset_random_walk * dt;
    cov = 0.5 * (cov + cov.transpose()).eval();
  } else if (P != nullptr) {
    // Ablation "without covariance propagation": every update starts from the same fixed prior
    // (keeping the last posterior instead makes the filter ever more confident until it
    // diverges). The fixed prior is a diagonal D carried over one scan interval T by the
    // transition at the current state, F_T·D·F_Tᵀ: without its position–velocity and
    // attitude–velocity couplings no LiDAR update could correct the velocity at all.
    StateCovariance& cov = *P;
    const std::pair<int, double> blocks[] = {{Idx::kPos, noise.fixed_position_std},
                                             {Idx::kRot, noise.fixed_rotation_std},
                                             {Idx::kVel, noise.fixed_velocity_std},
                                             {Idx::kBg, noise.fixed_gyro_bias_std},
                                             {Idx::kBa, noise.fixed_accel_bias_std}};
    StateCovariance D = cov;
    for (const auto& [idx, std] : blocks) {
      D.middleRows<3>(idx).setZero();
      D.middleCols<3>(idx).setZero();
    }
    for (const auto& [idx, std] : blocks) D.block<3, 3>(idx, idx).diagonal().setConstant(std * std);
    const double T = noise.fixed_prior_interval;
    StateCovariance F = StateCovariance::Identity();
    F.block<3, 3>(Idx::kPos, Idx::kVel) = Eigen::Matrix3d::Identity() * T;
    F.block<3, 3>(Idx::kRot, Idx::kBg) = -Eigen::Matrix3d::Identity() * T;
    F.block<3, 3>(Idx::kVel, Idx::kRot) = -x.R * so3::hat(a) * T;
    F.block<3, 3>(Idx::kVel, Idx::kBa) = -x.R * T;
    cov = F * D * F.transpose();
  }

  x.p += x.v * dt + 0.5 * a_W * dt * dt;
  x.v += a_W * dt;
  x.R = so3::Normalize(x.R * dR);
}

}  // namespace fuse

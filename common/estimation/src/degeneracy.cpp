#include "fuse/estimation/degeneracy.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace fuse {

void DegeneracyConfig::load(ConfigNode& node) {
  node.get("enabled", enabled).get("ratio_low", ratio_low).get("ratio_high", ratio_high);
  node.check(ratio_low >= 0.0 && ratio_low < 1.0, "ratio_low", "must be in [0, 1)");
  node.check(ratio_high > ratio_low && ratio_high <= 1.0, "ratio_high", "must be in (ratio_low, 1]");
  node.finish();
}

namespace {
double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}
}  // namespace

DegeneracyReport attenuate_degenerate_directions(LinearSystem& system, const DegeneracyConfig& config) {
  DegeneracyReport report;
  using Mat6 = Eigen::Matrix<double, 6, 6>;
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  const Mat6 info = system.information.topLeftCorner<6, 6>();
  report.min_eigenvalue_translation =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(info.topLeftCorner<3, 3>(), Eigen::EigenvaluesOnly).eigenvalues()(0);
  report.min_eigenvalue_rotation =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(info.bottomRightCorner<3, 3>(), Eigen::EigenvaluesOnly).eigenvalues()(0);

  // S maps the pose error to metres: θ_n = ℓ·θ, so Λ_n = S⁻¹ Λ S⁻¹ with S = diag(1, 1, 1, ℓ, ℓ, ℓ).
  const double ell = std::max(system.characteristic_length, 1e-3);
  Vec6 s_inv;
  s_inv << 1, 1, 1, 1 / ell, 1 / ell, 1 / ell;
  const Mat6 info_n = s_inv.asDiagonal() * info * s_inv.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Mat6> es(info_n);
  report.eigenvalues = es.eigenvalues();
  const double lambda_max = std::max(report.eigenvalues(5), 1e-300);
  for (int i = 0; i < 6; ++i) {
    const double ratio = std::max(report.eigenvalues(i), 0.0) / lambda_max;
    report.gamma(i) = smoothstep((ratio - config.ratio_low) / (config.ratio_high - config.ratio_low));
  }
  report.min_gamma = report.gamma.minCoeff();
  report.min_ratio = std::max(report.eigenvalues(0), 0.0) / lambda_max;
  if (!config.enabled || report.min_gamma >= 1.0) return report;

  // Λ'_n = U diag(γλ) Uᵀ, and the projector M_n = U diag(γ) Uᵀ for the gradient and cross terms.
  const Mat6& U = es.eigenvectors();
  const Mat6 info_att_n = U * (report.gamma.cwiseProduct(report.eigenvalues.cwiseMax(0.0))).asDiagonal() * U.transpose();
  const Mat6 M_n = U * report.gamma.asDiagonal() * U.transpose();
  // Back to original units: Λ' = S Λ'_n S; M = S M_n S⁻¹ (acts on the pose rows).
  const Vec6 s = s_inv.cwiseInverse();
  const Mat6 M = s.asDiagonal() * M_n * s_inv.asDiagonal();
  system.information.topLeftCorner<6, 6>() = s.asDiagonal() * info_att_n * s.asDiagonal();
  system.information.topRightCorner<6, kObsDim - 6>() = M * system.information.topRightCorner<6, kObsDim - 6>();
  system.information.bottomLeftCorner<kObsDim - 6, 6>() = system.information.topRightCorner<6, kObsDim - 6>().transpose();
  system.gradient.head<6>() = M * system.gradient.head<6>();
  return report;
}

}  // namespace fuse

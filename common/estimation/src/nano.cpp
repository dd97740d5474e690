#include "fuse/estimation/nano.hpp"

#include <Eigen/Cholesky>
#include <cmath>

namespace fuse {

namespace {
/// log det of a matrix from its Cholesky factor.
double log_det(const Eigen::LLT<Eigen::MatrixXd>& llt) {
  return 2.0 * llt.matrixLLT().diagonal().array().log().sum();
}

void accumulate(LinearSystem& sum, const LinearSystem& s, double w) {
  sum.information += w * s.information;
  sum.gradient += w * s.gradient;
  sum.cost += w * s.cost;
}
}  // namespace

UpdateResult NanoBackend::update(NavState& x, StateCovariance& P, MeasurementModel& model) {
  UpdateResult result;
  const NanoConfig& cfg = config_.nano;
  const ActiveSubspace active(P);
  const int n = active.size();
  if (n == 0) return result;
  const Eigen::MatrixXd& prior_info = active.prior_information();
  const NavState prior = x;
  const std::vector<int>& pose = active.pose();
  const int d = static_cast<int>(pose.size());
  const double beta = cfg.step;

  Eigen::VectorXd mu = Eigen::VectorXd::Zero(n);
  Eigen::MatrixXd Lambda = prior_info;
  Eigen::LLT<Eigen::MatrixXd> llt(Lambda);
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
  Eigen::MatrixXd Sigma = llt.solve(I);
  LinearSystem at_mean, point, expected;
  for (int it = 0; it < cfg.max_iterations; ++it) {
    // The mean: association and cost; the expectation when cubature is off.
    const NavState x_mean = prior.boxplus(active.scatter(mu));
    if (!model.linearize(x_mean, it, at_mean) || at_mean.count == 0) break;
    if (it == 0) result.cost_before = at_mean.cost;
    expected = at_mean;
    if (cfg.cubature && d > 0) {
      Eigen::MatrixXd S_pose(d, d);
      for (int r = 0; r < d; ++r) {
        for (int c = 0; c < d; ++c) S_pose(r, c) = Sigma(pose[r], pose[c]);
      }
      const Eigen::LLT<Eigen::MatrixXd> pose_llt(S_pose);
      const Eigen::MatrixXd L = pose_llt.matrixL();
      LinearSystem sum;
      sum.count = at_mean.count;
      sum.characteristic_length = at_mean.characteristic_length;
      bool ok = pose_llt.info() == Eigen::Success;
      const double radius = std::sqrt(static_cast<double>(d));
      for (int i = 0; ok && i < 2 * d; ++i) {
        Eigen::VectorXd m = mu;
        for (int r = 0; r < d; ++r) m(pose[r]) += (i % 2 == 0 ? radius : -radius) * L(r, i / 2);
        ok = model.linearize(prior.boxplus(active.scatter(m)), kCubatureIteration, point) && point.count > 0;
        if (ok) accumulate(sum, point, 1.0 / (2.0 * d));
      }
      if (ok) expected = sum;  // otherwise (a point without constraints): the mean alone
    }
    result.degeneracy = attenuate_degenerate_directions(expected, config_.degeneracy);

    // Natural-gradient step.
    Eigen::MatrixXd target = prior_info;
    active.add_information(expected, target);
    const Eigen::MatrixXd Lambda_new = (1.0 - beta) * Lambda + beta * target;
    const Eigen::LLT<Eigen::MatrixXd> llt_new(Lambda_new);
    const Eigen::VectorXd grad = active.gradient(expected) + prior_info * mu;
    const Eigen::VectorXd mu_new = mu - beta * llt_new.solve(grad);

    // KL(q_new ‖ q_old) = ½[tr(Λ_old Σ_new) − n + ΔμᵀΛ_old Δμ + ln|Λ_new| − ln|Λ_old|].
    const Eigen::MatrixXd Sigma_new = llt_new.solve(I);
    const Eigen::VectorXd dmu = mu_new - mu;
    const double kl = 0.5 * ((Lambda * Sigma_new).trace() - n + dmu.dot(Lambda * dmu) + log_det(llt_new) - log_det(llt));

    mu = mu_new;
    Lambda = Lambda_new;
    Sigma = Sigma_new;
    llt = llt_new;
    result.updated = true;
    result.iterations = it + 1;
    result.constraints = at_mean.count;
    result.cost_after = at_mean.cost;
    if (hook_) hook_(NanoIterate{it, mu, Lambda, kl, llt.info() == Eigen::Success});
    if (kl < cfg.kl_tolerance) {
      result.converged = true;
      break;
    }
  }
  if (!result.updated) return result;
  x = prior.boxplus(active.scatter(mu));
  P = active.scatter(Sigma);
  return result;
}

}  // namespace fuse

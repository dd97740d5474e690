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
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);

  struct Q {
    Eigen::VectorXd mu;
    Eigen::MatrixXd Lambda, Sigma;
    Eigen::LLT<Eigen::MatrixXd> llt;
  };
  Q q{Eigen::VectorXd::Zero(n), prior_info, Eigen::MatrixXd(), Eigen::LLT<Eigen::MatrixXd>(prior_info)};
  q.Sigma = q.llt.solve(I);
  // One natural-gradient step from q with the expected (attenuated) system.
  auto step = [&](const Q& from, const LinearSystem& expected) {
    Eigen::MatrixXd target = prior_info;
    active.add_information(expected, target);
    Q to;
    to.Lambda = (1.0 - beta) * from.Lambda + beta * target;
    to.llt.compute(to.Lambda);
    to.mu = from.mu - beta * to.llt.solve(Eigen::VectorXd(active.gradient(expected) + prior_info * from.mu));
    to.Sigma = to.llt.solve(I);
    return to;
  };
  // KL(a ‖ b) = ½[tr(Λ_b Σ_a) − n + (μ_a − μ_b)ᵀΛ_b(μ_a − μ_b) + ln|Λ_a| − ln|Λ_b|].
  auto kl = [&](const Q& a, const Q& b) {
    const Eigen::VectorXd dmu = a.mu - b.mu;
    return 0.5 * ((b.Lambda * a.Sigma).trace() - n + dmu.dot(b.Lambda * dmu) + log_det(a.llt) - log_det(b.llt));
  };

  bool cubature = cfg.cubature && d > 0;
  LinearSystem at_mean, point;
  for (int it = 0; it < cfg.max_iterations; ++it) {
    // The mean: association and cost; the expectation when cubature is off.
    if (!model.linearize(prior.boxplus(active.scatter(q.mu)), it, at_mean) || at_mean.count == 0) break;
    if (it == 0) result.cost_before = at_mean.cost;
    LinearSystem expected = at_mean;
    bool have_cubature = false;
    if (cubature) {
      Eigen::MatrixXd S_pose(d, d);
      for (int r = 0; r < d; ++r) {
        for (int c = 0; c < d; ++c) S_pose(r, c) = q.Sigma(pose[r], pose[c]);
      }
      const Eigen::LLT<Eigen::MatrixXd> pose_llt(S_pose);
      const Eigen::MatrixXd L = pose_llt.matrixL();
      LinearSystem sum;
      sum.count = at_mean.count;
      sum.characteristic_length = at_mean.characteristic_length;
      bool ok = pose_llt.info() == Eigen::Success;
      const double radius = std::sqrt(static_cast<double>(d));
      for (int i = 0; ok && i < 2 * d; ++i) {
        Eigen::VectorXd m = q.mu;
        for (int r = 0; r < d; ++r) m(pose[r]) += (i % 2 == 0 ? radius : -radius) * L(r, i / 2);
        ok = model.linearize(prior.boxplus(active.scatter(m)), kCubatureIteration, point) && point.count > 0;
        if (ok) accumulate(sum, point, 1.0 / (2.0 * d));
      }
      if (ok) {  // otherwise (a point without constraints): the mean alone
        expected = sum;
        have_cubature = true;
      }
    }
    result.degeneracy = attenuate_degenerate_directions(expected, config_.degeneracy);
    const Q next = step(q, expected);
    if (have_cubature && cfg.adaptive_cubature) {
      // The same step with the expectation at the mean: when the two differ by less than the KL
      // tolerance, the cubature no longer matters and later iterations take the mean only.
      attenuate_degenerate_directions(at_mean, config_.degeneracy);
      if (kl(next, step(q, at_mean)) < cfg.kl_tolerance) cubature = false;
    }
    const double kl_change = kl(next, q);
    q = next;
    result.updated = true;
    result.iterations = it + 1;
    result.constraints = at_mean.count;
    result.cost_after = at_mean.cost;
    if (hook_) hook_(NanoIterate{it, q.mu, q.Lambda, kl_change, q.llt.info() == Eigen::Success});
    if (kl_change < cfg.kl_tolerance) {
      result.converged = true;
      break;
    }
  }
  if (!result.updated) return result;
  x = prior.boxplus(active.scatter(q.mu));
  P = active.scatter(q.Sigma);
  return result;
}

}  // namespace fuse

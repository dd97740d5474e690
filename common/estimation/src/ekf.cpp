#include "fuse/estimation/ekf.hpp"

#include <Eigen/Cholesky>

namespace fuse {

StateVector kalman_step(NavState& x, StateCovariance& P, MeasurementModel& model, const DegeneracyConfig& degeneracy,
                        UpdateResult& result) {
  result = UpdateResult{};
  LinearSystem sys;
  if (!model.linearize(x, 0, sys) || sys.count == 0) return StateVector::Zero();
  const ActiveSubspace active(P);
  result.cost_before = result.cost_after = sys.cost;
  result.constraints = sys.count;
  result.degeneracy = attenuate_degenerate_directions(sys, degeneracy);
  Eigen::MatrixXd A = active.prior_information();
  active.add_information(sys, A);
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(A);
  const Eigen::MatrixXd P_post = ldlt.solve(Eigen::MatrixXd::Identity(active.size(), active.size()));
  const StateVector delta = active.scatter(Eigen::VectorXd(-(P_post * active.gradient(sys))));
  x = x.boxplus(delta);
  P = active.scatter(P_post);
  result.updated = true;
  result.converged = true;  // a single step has nothing to iterate on
  result.iterations = 1;
  return delta;
}

UpdateResult EkfBackend::update(NavState& x, StateCovariance& P, MeasurementModel& model) {
  UpdateResult result;
  kalman_step(x, P, model, config_.degeneracy, result);
  return result;
}

}  // namespace fuse

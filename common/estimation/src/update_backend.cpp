#include "fuse/estimation/update_backend.hpp"

#include <Eigen/Cholesky>
#include <algorithm>

#include "fuse/estimation/ekf.hpp"
#include "fuse/estimation/eskf.hpp"
#include "fuse/estimation/ieskf.hpp"
#include "fuse/estimation/nano.hpp"

namespace fuse {

namespace {
void load_ieskf_keys(ConfigNode& node, UpdateConfig& c) {
  node.get("max_iterations", c.max_iterations);
  node.get("convergence_translation", c.convergence_translation).get("convergence_rotation", c.convergence_rotation);
}

struct IeskfSection {
  UpdateConfig& c;
  void load(ConfigNode& node) {
    load_ieskf_keys(node, c);
    node.finish();
  }
};
}  // namespace

void NanoConfig::load(ConfigNode& node) {
  node.get("step", step).get("max_iterations", max_iterations);
  node.get("kl_tolerance", kl_tolerance).get("cubature", cubature).get("adaptive_cubature", adaptive_cubature);
  node.check(step > 0.0 && step <= 1.0, "step", "must be in (0, 1]");
  node.check(max_iterations >= 1 && max_iterations <= 100, "max_iterations", "must be in [1, 100]");
  node.check(kl_tolerance > 0.0, "kl_tolerance", "must be positive");
  node.finish();
}

const std::vector<std::string>& update_backend_names() {
  static const std::vector<std::string> names{"ekf", "eskf", "ieskf", "nano"};
  return names;
}

void UpdateConfig::load(ConfigNode& node) {
  node.get("backend", backend);
  load_ieskf_keys(node, *this);
  IeskfSection ieskf{*this};
  load_section(node, "ieskf", ieskf);
  load_section(node, "nano", nano);
  // EKF and ESKF have no keys of their own; accept empty sections for symmetry.
  node.child("ekf").finish();
  node.child("eskf").finish();
  load_section(node, "degeneracy", degeneracy);
  const auto& names = update_backend_names();
  node.check(std::find(names.begin(), names.end(), backend) != names.end(), "backend",
             "unknown update backend '" + backend + "' (known: ekf, eskf, ieskf, nano)");
  node.check(max_iterations >= 1 && max_iterations <= 50, "max_iterations", "must be in [1, 50]");
  node.check(convergence_translation > 0.0, "convergence_translation", "must be positive");
  node.check(convergence_rotation > 0.0, "convergence_rotation", "must be positive");
  node.finish();
}

std::unique_ptr<UpdateBackend> make_update_backend(const UpdateConfig& config) {
  if (config.backend == "ekf") return std::make_unique<EkfBackend>(config);
  if (config.backend == "eskf") return std::make_unique<EskfBackend>(config);
  if (config.backend == "ieskf") return std::make_unique<IeskfBackend>(config);
  if (config.backend == "nano") return std::make_unique<NanoBackend>(config);
  throw ConfigError("update.backend: unknown update backend '" + config.backend + "'");
}

ActiveSubspace::ActiveSubspace(const StateCovariance& P) {
  for (int i = 0; i < kStateDim; ++i) {
    if (P(i, i) > kFixedVariance) {
      const int a = static_cast<int>(index_.size());
      index_.push_back(i);
      if (i < kObsDim) observed_.insert(observed_.end(), {a, i});
      if (i < 6) pose_.push_back(a);
    }
  }
  const int n = size();
  Eigen::MatrixXd P_a(n, n);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) P_a(r, c) = P(index_[r], index_[c]);
  }
  prior_information_ = P_a.ldlt().solve(Eigen::MatrixXd::Identity(n, n));
}

void ActiveSubspace::add_information(const LinearSystem& sys, Eigen::MatrixXd& A, double scale) const {
  for (std::size_t r = 0; r < observed_.size(); r += 2) {
    for (std::size_t c = 0; c < observed_.size(); c += 2) {
      A(observed_[r], observed_[c]) += scale * sys.information(observed_[r + 1], observed_[c + 1]);
    }
  }
}

Eigen::VectorXd ActiveSubspace::gradient(const LinearSystem& sys) const {
  Eigen::VectorXd g = Eigen::VectorXd::Zero(size());
  for (std::size_t r = 0; r < observed_.size(); r += 2) g(observed_[r]) = sys.gradient(observed_[r + 1]);
  return g;
}

Eigen::VectorXd ActiveSubspace::gather(const StateVector& v) const {
  Eigen::VectorXd out(size());
  for (int r = 0; r < size(); ++r) out(r) = v(index_[r]);
  return out;
}

StateVector ActiveSubspace::scatter(const Eigen::VectorXd& v) const {
  StateVector out = StateVector::Zero();
  for (int r = 0; r < size(); ++r) out(index_[r]) = v(r);
  return out;
}

StateCovariance ActiveSubspace::scatter(const Eigen::MatrixXd& M) const {
  StateCovariance out = StateCovariance::Zero();
  for (int r = 0; r < size(); ++r) {
    for (int c = 0; c < size(); ++c) out(index_[r], index_[c]) = 0.5 * (M(r, c) + M(c, r));
  }
  return out;
}

}  // namespace fuse

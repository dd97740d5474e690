// Inference role (DESIGN §1): the posterior update at scan time behind one call. Backends are
// chosen by config (make_update_backend): ekf, eskf, ieskf, nano.
//
// Shared by all backends: only state dimensions with non-zero prior variance are estimated
// (ActiveSubspace), the measurement enters as the normal equations of the observed block
// (MeasurementModel → LinearSystem), and its pose information is attenuated along weak
// directions before use (degeneracy.hpp).
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "fuse/core/config.hpp"
#include "fuse/estimation/degeneracy.hpp"
#include "fuse/estimation/measurement_model.hpp"
#include "fuse/estimation/state.hpp"

namespace fuse {

/// NANO's own keys (update.nano.*), see nano.hpp.
struct NanoConfig {
  double step = 1.0;           ///< β ∈ (0, 1]: natural-gradient step
  int max_iterations = 5;      ///< iteration cap
  double kl_tolerance = 1e-2;  ///< nats: stop when KL(q_new ‖ q_old) falls below this
  bool cubature = true;        ///< expectations by spherical-radial cubature over the pose (off: at the mean)
  /// Drop the cubature for the remaining iterations once it changes the step by less than kl_tolerance.
  bool adaptive_cubature = true;
  void load(ConfigNode& node);
};

struct UpdateConfig {
  std::string backend = "ieskf";  ///< ekf | eskf | ieskf | nano
  // IESKF keys: flat (update.max_iterations, ...) or in update.ieskf (the section wins).
  int max_iterations = 5;                 ///< iteration cap
  double convergence_translation = 1e-3;  ///< m: stop when the step is smaller (and ...)
  double convergence_rotation = 1e-4;     ///< rad: ... the rotation step is smaller
  NanoConfig nano;                        ///< update.nano
  DegeneracyConfig degeneracy;            ///< shared by every backend
  void load(ConfigNode& node);
};

struct UpdateResult {
  bool updated = false;  ///< false when the model had no constraints
  bool converged = false;
  int iterations = 0;
  std::size_t constraints = 0;
  double cost_before = 0.0, cost_after = 0.0;
  DegeneracyReport degeneracy;
};

class UpdateBackend {
 public:
  virtual ~UpdateBackend() = default;
  /// Prior (x, P) in, posterior (x, P) out.
  virtual UpdateResult update(NavState& x, StateCovariance& P, MeasurementModel& model) = 0;
  virtual std::string name() const = 0;
};

/// Names accepted by make_update_backend.
const std::vector<std::string>& update_backend_names();
std::unique_ptr<UpdateBackend> make_update_backend(const UpdateConfig& config);

/// The estimated dimensions of the error state (prior variance above a floor) and the prior
/// information over them. Vectors and matrices over these dimensions are "active" (size n).
class ActiveSubspace {
 public:
  /// A variance at or below this is a fixed state dimension (e.g. extrinsic not estimated).
  static constexpr double kFixedVariance = 1e-24;

  explicit ActiveSubspace(const StateCovariance& P);
  int size() const { return static_cast<int>(index_.size()); }
  const std::vector<int>& index() const { return index_; }
  /// (P_a)⁻¹, the prior information over the active dimensions.
  const Eigen::MatrixXd& prior_information() const { return prior_information_; }
  /// Active positions of the pose block [δp, δθ] (state dims 0..5) that are estimated.
  const std::vector<int>& pose() const { return pose_; }

  /// A += scale · Λ (the system's observed-block information, placed on the active dimensions).
  void add_information(const LinearSystem& sys, Eigen::MatrixXd& A, double scale = 1.0) const;
  /// The system's gradient Σ w Hᵀr on the active dimensions.
  Eigen::VectorXd gradient(const LinearSystem& sys) const;
  Eigen::VectorXd gather(const StateVector& v) const;
  StateVector scatter(const Eigen::VectorXd& v) const;
  /// The full covariance with M (symmetrised) on the active dimensions and zeros elsewhere.
  StateCovariance scatter(const Eigen::MatrixXd& M) const;

 private:
  std::vector<int> index_;     ///< state dimension of each active position
  std::vector<int> observed_;  ///< (active position, observed-block dimension) pairs, flattened
  std::vector<int> pose_;
  Eigen::MatrixXd prior_information_;
};

}  // namespace fuse

// Inference role (DESIGN §1): the posterior update at scan time behind one call. Backends are
// chosen by config (make_update_backend).
#pragma once

#include <memory>
#include <string>

#include "fuse/core/config.hpp"
#include "fuse/estimation/degeneracy.hpp"
#include "fuse/estimation/measurement_model.hpp"
#include "fuse/estimation/state.hpp"

namespace fuse {

struct UpdateConfig {
  std::string backend = "ieskf";    ///< ieskf (EKF, ESKF, NANO follow)
  int max_iterations = 5;           ///< iteration cap
  double convergence_translation = 1e-3;  ///< m: stop when the step is smaller (and ...)
  double convergence_rotation = 1e-4;     ///< rad: ... the rotation step is smaller
  DegeneracyConfig degeneracy;
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

std::unique_ptr<UpdateBackend> make_update_backend(const UpdateConfig& config);

}  // namespace fuse

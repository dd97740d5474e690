#include "fuse/estimation/update_backend.hpp"

#include "fuse/estimation/ieskf.hpp"

namespace fuse {

void UpdateConfig::load(ConfigNode& node) {
  node.get("backend", backend).get("max_iterations", max_iterations);
  node.get("convergence_translation", convergence_translation).get("convergence_rotation", convergence_rotation);
  load_section(node, "degeneracy", degeneracy);
  node.check(backend == "ieskf", "backend", "unknown update backend '" + backend + "' (known: ieskf)");
  node.check(max_iterations >= 1 && max_iterations <= 50, "max_iterations", "must be in [1, 50]");
  node.check(convergence_translation > 0.0, "convergence_translation", "must be positive");
  node.check(convergence_rotation > 0.0, "convergence_rotation", "must be positive");
  node.finish();
}

std::unique_ptr<UpdateBackend> make_update_backend(const UpdateConfig& config) {
  if (config.backend == "ieskf") return std::make_unique<IeskfBackend>(config);
  throw ConfigError("update.backend: unknown update backend '" + config.backend + "'");
}

}  // namespace fuse

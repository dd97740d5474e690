#include <stdexcept>

#include "backends.hpp"

namespace fuse::transport {

std::unique_ptr<Participant> make_participant(const TransportConfig& config, const std::string& name) {
  if (config.domain_id < 0 || config.domain_id > 101) {
    throw std::runtime_error("transport: domain_id " + std::to_string(config.domain_id) + " is outside [0, 101]");
  }
  if (config.vendor == "fastdds") return detail::make_fastdds_participant(config, name);
  if (config.vendor == "cyclonedds") return detail::make_cyclonedds_participant(config, name);
  throw std::runtime_error("transport: unknown vendor '" + config.vendor + "' (fastdds | cyclonedds)");
}

}  // namespace fuse::transport

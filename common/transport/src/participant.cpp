#include <stdexcept>

#include "backends.hpp"

namespace fuse::transport {

namespace {
thread_local const detail::SenderLookup* tl_sender = nullptr;
}  // namespace

std::string current_sender() { return tl_sender != nullptr ? tl_sender->sender() : std::string(); }

detail::SenderScope::SenderScope(const SenderLookup* lookup) : previous_(tl_sender) { tl_sender = lookup; }
detail::SenderScope::~SenderScope() { tl_sender = previous_; }

std::unique_ptr<Participant> make_participant(const TransportConfig& config, const std::string& name) {
  if (config.domain_id < 0 || config.domain_id > 101) {
    throw std::runtime_error("transport: domain_id " + std::to_string(config.domain_id) + " is outside [0, 101]");
  }
  if (config.vendor == "fastdds") return detail::make_fastdds_participant(config, name);
  if (config.vendor == "cyclonedds") return detail::make_cyclonedds_participant(config, name);
  throw std::runtime_error("transport: unknown vendor '" + config.vendor + "' (fastdds | cyclonedds)");
}

}  // namespace fuse::transport

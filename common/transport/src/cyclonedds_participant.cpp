#include <stdexcept>

#include "backends.hpp"

namespace fuse::transport::detail {

std::unique_ptr<Participant> make_cyclonedds_participant(const TransportConfig&, const std::string&) {
  throw std::runtime_error("transport: the Cyclone DDS backend is not available yet");
}

}  // namespace fuse::transport::detail

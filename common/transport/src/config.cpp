#include "fuse/transport/transport.hpp"

#include <arpa/inet.h>

#include <utility>

#include "fuse/core/plain_name.hpp"

namespace fuse::transport {

void TransportConfig::load(ConfigNode& node) {
  node.get("vendor", vendor).get("domain_id", domain_id).get("loopback_only", loopback_only);
  node.get("max_participants", max_participants).get("socket_buffer_bytes", socket_buffer_bytes);
  node.get("shared_memory", shared_memory).get("system_name", system_name);
  node.get("interfaces", interfaces).get("peers", peers);
  node.check(vendor == "fastdds" || vendor == "cyclonedds", "vendor", "must be fastdds or cyclonedds");
  // Ports are 7400 + 250 * domain + ...: above 101 they run into the ephemeral range.
  node.check(domain_id >= 0 && domain_id <= 101, "domain_id", "must be in [0, 101]");
  // Both vendors probe one unicast port per participant index up to this bound on 127.0.0.1.
  node.check(max_participants >= 4 && max_participants <= 120, "max_participants", "must be in [4, 120]");
  node.check(socket_buffer_bytes >= (64u << 10) && socket_buffer_bytes <= (256u << 20), "socket_buffer_bytes",
             "must be in [64 KiB, 256 MiB]");
  node.check(system_name.size() <= 64 && has_only_plain_name_chars(system_name), "system_name", "must be at most 64 letters, digits, '_', '-' or '.' (empty: the default partition)");
  for (const auto& [key, list] : {std::pair<const char*, const std::vector<std::string>*>{"interfaces", &interfaces},
                                  {"peers", &peers}}) {
    node.check(loopback_only == false || list->empty(), key, "needs loopback_only: false (loopback is 127.0.0.1 only)");
    node.check(list->size() <= 64, key, "at most 64 addresses");
    for (const std::string& a : *list) {
      in_addr parsed{};
      node.check(inet_pton(AF_INET, a.c_str(), &parsed) == 1, key, "'" + a + "' is not an IPv4 address (a.b.c.d)");
    }
  }
  load_section(node, "security", security);
  node.finish();
}

}  // namespace fuse::transport

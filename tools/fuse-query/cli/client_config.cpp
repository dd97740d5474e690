#include "client_config.hpp"

#include <yaml-cpp/yaml.h>

#include "fuse/core/config.hpp"
#include "fuse/transport/transport.hpp"

namespace fuse::query_tool {

namespace {
YAML::Node load_yaml(const std::string& file) {
  if (file.empty()) return YAML::Node(YAML::NodeType::Map);
  return load_yaml_file(file, {});  // an empty file, or one that is not a map of sections, is refused
}

/// Sets node[parts[i]][parts[i+1]]... = value, creating maps on the way. (A YAML::Node is passed
/// by value: assigning one node to another would overwrite the first one's content.)
void set_path(YAML::Node node, const std::vector<std::string>& parts, std::size_t i, const YAML::Node& value) {
  if (i + 1 == parts.size()) {
    node[parts[i]] = value;
    return;
  }
  if (!node[parts[i]] || !node[parts[i]].IsMap()) node[parts[i]] = YAML::Node(YAML::NodeType::Map);
  set_path(node[parts[i]], parts, i + 1, value);
}

/// Applies "a.b.c=value" to the config tree, the value parsed as YAML (numbers, bools, lists).
void apply_override(YAML::Node root, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) throw ConfigError("override '" + assignment + "' is not key=value");
  YAML::Node value;
  try {
    value = YAML::Load(assignment.substr(eq + 1));
  } catch (const YAML::Exception&) {
    throw ConfigError("override '" + assignment + "': value is not valid YAML");
  }
  const std::string key = assignment.substr(0, eq);
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t dot; (dot = key.find('.', start)) != std::string::npos; start = dot + 1) {
    parts.push_back(key.substr(start, dot - start));
  }
  parts.push_back(key.substr(start));
  set_path(root, parts, 0, value);
}
}  // namespace

query::ClientOptions load_client_options(const std::string& file, const std::vector<std::string>& overrides) {
  YAML::Node root = load_yaml(file);
  for (const auto& o : overrides) apply_override(root, o);
  ConfigNode node(root, "");
  transport::TransportConfig t;
  load_section(node, "transport", t);
  query::ClientOptions options;
  options.vendor = t.vendor;
  options.domain_id = t.domain_id;
  options.loopback_only = t.loopback_only;
  options.max_participants = t.max_participants;
  options.shared_memory = t.shared_memory;
  options.socket_buffer_bytes = t.socket_buffer_bytes;
  options.system_name = t.system_name;
  options.security = t.security.enabled;
  options.security_keystore = t.security.keystore;
  options.security_identity = t.security.identity;
  options.security_private_key = t.security.private_key;
  options.interfaces = t.interfaces;
  options.peers = t.peers;
  return options;
}

}  // namespace fuse::query_tool

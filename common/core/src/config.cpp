#include "fuse/core/config.hpp"

namespace fuse {

ConfigNode::ConfigNode(YAML::Node node, std::string path) : node_(std::move(node)), path_(std::move(path)) {
  if (node_.IsDefined() && !node_.IsNull() && !node_.IsMap()) {
    throw ConfigError((path_.empty() ? std::string("config") : path_) + ": expected a map of keys");
  }
}

ConfigNode ConfigNode::from_file(const std::string& file) { return ConfigNode(load_yaml_file(file), ""); }

ConfigNode ConfigNode::from_string(const std::string& text) {
  try {
    return ConfigNode(YAML::Load(text), "");
  } catch (const YAML::ParserException& e) {
    throw ConfigError(std::string("config is not valid YAML: ") + e.what());
  }
}

namespace {
template <int N>
void read_vector(const YAML::Node& node, const std::string& path, Eigen::Matrix<double, N, 1>& value) {
  if (!node.IsSequence() || node.size() != static_cast<std::size_t>(N)) {
    throw ConfigError(path + ": expected a list of " + std::to_string(N) + " numbers");
  }
  for (int i = 0; i < N; ++i) {
    try {
      value[i] = node[i].as<double>();
    } catch (const YAML::Exception&) {
      throw ConfigError(path + ": element " + std::to_string(i) + " is not a number");
    }
  }
}
}  // namespace

ConfigNode& ConfigNode::get(const std::string& key, Eigen::Vector3d& value) {
  used_.insert(key);
  if (node_.IsDefined() && !node_.IsNull() && node_[key]) read_vector<3>(node_[key], key_path(key), value);
  return *this;
}

ConfigNode& ConfigNode::get(const std::string& key, Eigen::Vector4d& value) {
  used_.insert(key);
  if (node_.IsDefined() && !node_.IsNull() && node_[key]) read_vector<4>(node_[key], key_path(key), value);
  return *this;
}

bool ConfigNode::has(const std::string& key) const {
  return node_.IsDefined() && !node_.IsNull() && static_cast<bool>(node_[key]);
}

ConfigNode ConfigNode::child(const std::string& key) {
  used_.insert(key);
  YAML::Node sub = has(key) ? node_[key] : YAML::Node();
  return ConfigNode(sub, key_path(key));
}

void ConfigNode::finish() const {
  if (!node_.IsDefined() || node_.IsNull()) return;
  std::string unknown;
  for (const auto& kv : node_) {
    const auto key = kv.first.as<std::string>();
    if (!used_.count(key)) unknown += (unknown.empty() ? "" : ", ") + key_path(key);
  }
  if (!unknown.empty()) throw ConfigError("unknown config key(s): " + unknown);
}

void ConfigNode::check(bool ok, const std::string& key, const std::string& what) const {
  if (!ok) throw ConfigError(key_path(key) + ": " + what);
}

namespace {
/// Sets node[a][b][c] = value for key "a.b.c", parsing value as YAML (numbers, bools, lists).
void apply_override(YAML::Node root, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) throw ConfigError("override '" + assignment + "' is not key=value");
  const std::string key = assignment.substr(0, eq);
  YAML::Node value;
  try {
    value = YAML::Load(assignment.substr(eq + 1));
  } catch (const YAML::Exception&) {
    throw ConfigError("override '" + assignment + "': value is not valid YAML");
  }
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t dot; (dot = key.find('.', start)) != std::string::npos; start = dot + 1) {
    parts.push_back(key.substr(start, dot - start));
  }
  parts.push_back(key.substr(start));
  std::vector<YAML::Node> chain{root};
  for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
    YAML::Node next = chain.back()[parts[i]];
    if (!next.IsDefined() || next.IsNull()) next = YAML::Node(YAML::NodeType::Map);
    chain.back()[parts[i]] = next;
    chain.push_back(chain.back()[parts[i]]);
  }
  chain.back()[parts.back()] = value;
}

}  // namespace

YAML::Node load_yaml_file(const std::string& file, const std::vector<std::string>& overrides) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(file);
  } catch (const YAML::BadFile&) {
    throw ConfigError("cannot open config file '" + file + "'");
  } catch (const YAML::ParserException& e) {
    throw ConfigError("config file '" + file + "' is not valid YAML: " + e.what());
  }
  // An empty file (or one holding only comments) would silently run on every default: refused, as
  // is a file whose top level is not a map of sections.
  if (!root.IsDefined() || root.IsNull()) throw ConfigError("config file '" + file + "' is empty");
  if (!root.IsMap()) throw ConfigError("config file '" + file + "' is not a YAML mapping of sections");
  for (const auto& o : overrides) apply_override(root, o);
  return root;
}

}  // namespace fuse

#include "fuse/core/config.hpp"

namespace fuse {

ConfigNode::ConfigNode(YAML::Node node, std::string path) : node_(std::move(node)), path_(std::move(path)) {
  if (node_.IsDefined() && !node_.IsNull() && !node_.IsMap()) {
    throw ConfigError((path_.empty() ? std::string("config") : path_) + ": expected a map of keys");
  }
}

ConfigNode ConfigNode::from_file(const std::string& file) {
  try {
    return ConfigNode(YAML::LoadFile(file), "");
  } catch (const YAML::BadFile&) {
    throw ConfigError("cannot open config file '" + file + "'");
  } catch (const YAML::ParserException& e) {
    throw ConfigError("config file '" + file + "' is not valid YAML: " + e.what());
  }
}

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

}  // namespace fuse

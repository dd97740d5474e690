// Typed YAML configuration. Each module has one config struct with defaults and a
// `load(ConfigNode&)` that reads its keys; ConfigNode remembers which keys were read so that
// finish() can refuse unknown keys, naming them with their full path (e.g. "update.max_iter").
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace fuse {

/// A configuration that is malformed, has an unknown key or a value out of range.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class ConfigNode {
 public:
  ConfigNode(YAML::Node node, std::string path);
  static ConfigNode from_file(const std::string& file);
  static ConfigNode from_string(const std::string& text);

  /// Reads `key` into value when present (keeps the default otherwise); wrong type -> ConfigError.
  template <typename T>
  ConfigNode& get(const std::string& key, T& value);
  ConfigNode& get(const std::string& key, Eigen::Vector3d& value);
  ConfigNode& get(const std::string& key, Eigen::Vector4d& value);

  bool has(const std::string& key) const;
  /// A sub-map; an absent key gives an empty node (all defaults).
  ConfigNode child(const std::string& key);
  /// Throws ConfigError naming every key of this node that nobody read (children check their own).
  void finish() const;
  /// Throws ConfigError "<path.key>: <what>" unless ok.
  void check(bool ok, const std::string& key, const std::string& what) const;

  const std::string& path() const { return path_; }
  std::string key_path(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

 private:
  YAML::Node node_;
  std::string path_;
  std::set<std::string> used_;
};

/// Reads a YAML file and applies "dotted.key=value" overrides (the value parsed as YAML, e.g.
/// estimator.update.max_iterations=3). Unreadable file, bad YAML or a malformed override ->
/// ConfigError naming it.
YAML::Node load_yaml_file(const std::string& file, const std::vector<std::string>& overrides = {});

/// Loads the sub-map `key` of parent into a config struct with a `load(ConfigNode&)` member.
template <typename Section>
void load_section(ConfigNode& parent, const std::string& key, Section& section) {
  ConfigNode child = parent.child(key);
  section.load(child);
}

template <typename T>
ConfigNode& ConfigNode::get(const std::string& key, T& value) {
  used_.insert(key);
  if (!node_.IsDefined() || node_.IsNull() || !node_[key]) return *this;
  try {
    value = node_[key].template as<T>();
  } catch (const YAML::Exception&) {
    throw ConfigError(key_path(key) + ": cannot read value '" + YAML::Dump(node_[key]) + "' as the expected type");
  }
  return *this;
}

}  // namespace fuse

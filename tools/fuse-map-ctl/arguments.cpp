#include "arguments.hpp"

#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <cstdlib>
#include <filesystem>

#include "fuse/core/config.hpp"

namespace fuse::map_ctl {

namespace {
int parse_deadline(const std::string& name, const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || v <= 0 || v > 3'600'000) {
    throw ArgumentError(name + ": '" + text + "' is not a positive number of milliseconds");
  }
  return static_cast<int>(v);
}

/// Sets root[a][b][c] = value for "a.b.c=value", the value parsed as YAML (numbers, bools).
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
  YAML::Node node = root;
  std::size_t start = 0;
  for (std::size_t dot; (dot = key.find('.', start)) != std::string::npos; start = dot + 1) {
    const std::string part = key.substr(start, dot - start);
    if (!node[part] || !node[part].IsMap()) node[part] = YAML::Node(YAML::NodeType::Map);
    node.reset(node[part]);  // reset: plain assignment would overwrite the parent's content
  }
  node[key.substr(start)] = value;
}
}  // namespace

Arguments parse_arguments(const std::vector<std::string>& args) {
  Arguments a;
  std::string domain, vendor;
  auto set_command = [&](Command c, const std::string& arg) {
    if (a.command != Command::kNone) throw ArgumentError("'" + arg + "': give one command only");
    a.command = c;
  };
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    auto value = [&]() -> const std::string& {
      if (i + 1 >= args.size()) throw ArgumentError(arg + " needs a value");
      return args[++i];
    };
    auto has_operand = [&] { return i + 1 < args.size() && args[i + 1].rfind("--", 0) != 0; };
    if (arg == "--help" || arg == "-h") {
      a.help = true;
    } else if (arg == "--json") {
      a.json = true;
    } else if (arg == "--deadline-ms") {
      a.deadline_ms = parse_deadline(arg, value());
    } else if (arg == "--config") {
      a.config_file = value();
    } else if (arg == "--set") {
      a.overrides.push_back(value());
    } else if (arg == "--domain") {
      domain = value();
    } else if (arg == "--vendor") {
      vendor = value();
    } else if (arg == "--mode") {
      set_command(Command::kSetMode, arg);
      a.mode = value();
      if (a.mode != "mapping" && a.mode != "localization") {
        throw ArgumentError("--mode: '" + a.mode + "' is not mapping or localization");
      }
    } else if (arg == "stats") {
      set_command(Command::kStats, arg);
    } else if (arg == "save") {
      set_command(Command::kSave, arg);
      if (has_operand()) a.file = args[++i];
    } else if (arg == "load") {
      set_command(Command::kLoad, arg);
      if (!has_operand()) throw ArgumentError("load needs a snapshot FILE");
      a.file = args[++i];
    } else {
      throw ArgumentError("unknown argument '" + arg + "'");
    }
  }
  if (a.help) return a;
  if (a.command == Command::kNone) throw ArgumentError("no command (--mode, save, load or stats)");
  if (!a.file.empty()) a.file = std::filesystem::absolute(a.file).lexically_normal().string();
  // After every --set: the explicit options win.
  if (!domain.empty()) a.overrides.push_back("transport.domain_id=" + domain);
  if (!vendor.empty()) a.overrides.push_back("transport.vendor=" + vendor);
  return a;
}

std::string usage() {
  return "usage: fuse-map-ctl [--config FILE] [--set key=value]... [--domain N] [--vendor fastdds|cyclonedds]\n"
         "                    [--deadline-ms N] [--json]\n"
         "                    (--mode mapping|localization | save [FILE] | load FILE | stats)\n"
         "  Controls the running map server (fuse-map) through its map/control service.\n"
         "  --mode M:   mapping (observations change the map) or localization (the map is frozen)\n"
         "  save [FILE]: a snapshot into the map directory, or into FILE (prints the path written)\n"
         "  load FILE:  replaces the map by a snapshot file's (the epoch increases)\n"
         "  stats:      state (running | degraded, and why), mode, epoch, points, chunks, acknowledged\n"
         "              sequence, journal records and write errors, observations pending in memory\n"
         "              (not journaled yet) and dropped, damage skipped at load, and the acknowledged\n"
         "              sequence of each recently active session\n"
         "  --config:   a FUSE config; only its transport: section is read (default: domain 0)\n"
         "  --deadline-ms N: give up after N ms without a reply (default 5000)\n"
         "  --json:     print one JSON object\n"
         "  exit codes: 0 done, 2 usage or config, 3 error reply, 4 no server answered before the deadline\n";
}

transport::TransportConfig load_transport_config(const std::string& file, const std::vector<std::string>& overrides) {
  YAML::Node root = file.empty() ? YAML::Node(YAML::NodeType::Map) : load_yaml_file(file);
  if (!root.IsMap()) root = YAML::Node(YAML::NodeType::Map);
  for (const std::string& o : overrides) apply_override(root, o);
  ConfigNode node(root, "");
  transport::TransportConfig config;
  load_section(node, "transport", config);
  return config;
}

}  // namespace fuse::map_ctl

#include "arguments.hpp"

#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "fuse/cli/cli.hpp"

#include "fuse/core/config.hpp"
#include "fuse/map/map_names.hpp"

namespace fuse::map_ctl {

namespace {
int parse_deadline(const std::string& name, const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || v <= 0 || v > 3'600'000) {
    throw std::invalid_argument(name + ": '" + text + "' is not a positive number of milliseconds");
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

std::optional<int> parse_arguments(int argc, char** argv, Arguments& a) {
  const auto app = cli::make_app(
      "fuse-map-ctl",
      "Controls the running map server (fuse-map) through its map/control service: one command, --mode M, "
      "save [NAME], load NAME or stats; prints the map's state after it (or one JSON object). A NAME is a saved "
      "map's file name in the map server's directory of saved maps (map_server.saved_directory, by default "
      "DIR/saved); paths are refused. set-pose gives the estimator (fuse-update's update/set_pose service) a "
      "pose in the map to search around, as rviz's 2D Pose Estimate, and prints its verdict.",
      "Exit codes: 0 done (set-pose: accepted or corrected), 2 usage or config, 3 error reply (set-pose: "
      "refused), 4 no server answered before the deadline, 5 set-pose still being checked after --wait.");
  std::string deadline;
  app->add_option("--mode", a.mode, "mapping (observations change the map) or localization (the map is frozen)")
      ->type_name("M")
      ->check(CLI::IsMember({"mapping", "localization"}));
  app->add_option("--config", a.config_file, "a FUSE config; only its transport: section is read (default: domain 0)")
      ->type_name("FILE");
  const cli::TransportFlags transport(*app);
  app->add_option("--deadline-ms", deadline, "give up after N ms without a reply (default 5000)")->type_name("N");
  app->add_flag("--json", a.json, "print one JSON object");
  app->fallthrough();  // before the commands, which inherit it: the options may also follow them
  CLI::App* stats = app->add_subcommand(
      "stats",
      "state (running | degraded, and why), mode, epoch, points, chunks, acknowledged sequence, journal records "
      "and write errors, observations pending in memory and dropped, damage skipped at load, and the "
      "acknowledged sequence of each recently active session");
  CLI::App* save = app->add_subcommand(
      "save", "a snapshot into the map directory, or a copy named NAME into the saved maps (prints the path)");
  save->add_option("NAME", a.file, "saved map's name (letters, digits, '.', '_', '-')");
  CLI::App* load = app->add_subcommand("load", "replaces the map by the saved map NAME (the epoch increases)");
  load->add_option("NAME", a.file, "saved map's name")->required();
  load->add_flag("--other-system", a.other_system,
                 "NAME was recorded by another system (another transport.system_name): replace this system's map "
                 "with it anyway (fuse-map logs it); without it such a load is refused");
  CLI::App* set_pose = app->add_subcommand(
      "set-pose",
      "an initial pose in the saved map: the IMU at X Y Z (m) heading YAW_DEG (deg) in the map frame; the estimator "
      "searches within 3 sigma of it and says whether it was accepted, corrected (located more than 0.5 m or 5 deg "
      "away) or refused (nothing there fits the map)");
  set_pose->add_option("POSE", a.pose, "X Y Z YAW_DEG")->expected(4)->required()->allow_extra_args(false);
  set_pose->add_option("--std-xy", a.std_xy, "position sigma, m (default 1)")->check(CLI::Range(0.01, 100.0));
  set_pose->add_option("--std-yaw", a.std_yaw, "heading sigma, deg (default 10)")->check(CLI::Range(0.1, 180.0));
  set_pose->add_option("--wait", a.wait_s, "seconds to wait for the verdict (default 10, at most 30)")
      ->check(CLI::Range(0.0, 30.0));
  set_pose->add_option("--time", a.time,
                       "sensor time (s) the pose holds for, within the last 60 s (fuse-query prints it; default: now)")
      ->check(CLI::PositiveNumber);
  app->require_subcommand(0, 1);
  if (const std::optional<int> code = cli::parse(*app, argc, argv)) return code;

  const int commands = (app->count("--mode") > 0 ? 1 : 0) + (stats->parsed() ? 1 : 0) + (save->parsed() ? 1 : 0) +
                       (load->parsed() ? 1 : 0) + (set_pose->parsed() ? 1 : 0);
  if (commands == 0) return cli::usage_error(*app, "no command (--mode, save, load, stats or set-pose)");
  if (commands > 1) return cli::usage_error(*app, "give one command only (--mode, save, load, stats or set-pose)");
  a.command = app->count("--mode") > 0 ? Command::kSetMode
              : stats->parsed()        ? Command::kStats
              : save->parsed()         ? Command::kSave
              : set_pose->parsed()     ? Command::kSetPose
                                       : Command::kLoad;
  if (set_pose->parsed() && a.pose.size() != 4) return cli::usage_error(*set_pose, "POSE: give X Y Z YAW_DEG");
  for (const double v : a.pose) {
    if (!std::isfinite(v) || std::abs(v) > 1e6) return cli::usage_error(*set_pose, "POSE: X Y Z YAW_DEG must be finite numbers");
  }
  try {
    if (!deadline.empty()) a.deadline_ms = parse_deadline("--deadline-ms", deadline);
  } catch (const std::invalid_argument& e) {
    return cli::usage_error(*app, e.what());
  }
  if (!a.file.empty()) {
    if (const std::string why = invalid_map_name(a.file); !why.empty()) return cli::usage_error(*app, "NAME: " + why);
  }
  // After every --set: the explicit options win.
  a.overrides = transport.sets();
  const std::vector<std::string> shorthands = transport.shorthands();
  a.overrides.insert(a.overrides.end(), shorthands.begin(), shorthands.end());
  return std::nullopt;
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

// Command line of fuse-map-ctl, and the transport settings it joins the services with.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "fuse/transport/transport.hpp"

namespace fuse::map_ctl {

enum class Command { kNone, kStats, kSetMode, kSave, kLoad, kSetPose };

struct Arguments {
  Command command = Command::kNone;
  std::string mode;  ///< --mode: mapping | localization
  std::string file;  ///< save [NAME] / load NAME: a saved map's name (fuse/map/map_names.hpp)
  std::string config_file;             ///< optional: its `transport:` section
  std::vector<std::string> overrides;  ///< --set dotted.key=value in order, then --domain, --vendor
  int deadline_ms = 5000;
  bool json = false;
  bool other_system = false;  ///< load NAME --other-system: NAME may be another system's map
  /// set-pose X Y Z YAW_DEG: the IMU's pose in the map frame, its sigmas and how long to wait
  std::vector<double> pose;
  double std_xy = 1.0;    ///< m
  double std_yaw = 10.0;  ///< deg
  double wait_s = 10.0;
  double time = 0.0;  ///< sensor time the pose holds for; 0: now
};

/// Parses and checks argv into `a` (CLI11, the convention of every binary: fuse/cli/cli.hpp).
/// std::nullopt: go on; otherwise the exit code to end with (0 after --help / --version, 2 after
/// a usage error, printed naming the flag).
std::optional<int> parse_arguments(int argc, char** argv, Arguments& a);

/// The `transport:` section of `file` (none: the defaults, domain 0) with the overrides applied;
/// the file's other sections are not read. Throws fuse::ConfigError.
transport::TransportConfig load_transport_config(const std::string& file, const std::vector<std::string>& overrides);

}  // namespace fuse::map_ctl

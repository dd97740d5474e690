#include "fuse/launch/launch_plan.hpp"

#include <charconv>
#include <filesystem>

namespace fuse::launch {

namespace {
std::string number(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, r.ptr);
}

std::string microseconds(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v, std::chars_format::fixed, 6);
  return std::string(buf, r.ptr);
}

std::string path_in(const std::string& dir, const std::string& name) {
  return (std::filesystem::path(dir) / name).string();
}

/// The part every service gets: the config and the overrides, the launcher's own last (they win).
std::vector<std::string> common_arguments(const LaunchOptions& o) {
  std::vector<std::string> args{"--config", o.config_file};
  for (const auto& s : service_overrides(o)) args.insert(args.end(), {"--set", s});
  return args;
}

ServiceSpec service(const LaunchOptions& o, const std::string& name, const std::vector<std::string>& extra) {
  ServiceSpec spec;
  spec.name = name;
  spec.argv = {path_in(o.bin_dir, name)};
  const auto common = common_arguments(o);
  spec.argv.insert(spec.argv.end(), common.begin(), common.end());
  spec.argv.insert(spec.argv.end(), extra.begin(), extra.end());
  spec.restart = o.restart;
  return spec;
}
}  // namespace

std::vector<std::string> service_overrides(const LaunchOptions& o) {
  std::vector<std::string> out = o.overrides;
  if (o.domain_id) out.push_back("transport.domain_id=" + std::to_string(*o.domain_id));
  if (!o.vendor.empty()) out.push_back("transport.vendor=" + o.vendor);
  return out;
}

LaunchPlan make_launch_plan(const LaunchOptions& o, double start_wall) {
  LaunchPlan plan;
  plan.log_dir = path_in(o.out_dir, "logs");
  const std::string map_dir = o.map_dir.empty() ? path_in(o.out_dir, "map") : o.map_dir;
  plan.map_dir = map_dir;
  plan.trajectory_file = path_in(o.out_dir, "trajectory.tum");
  // The spill directory (pending observations while the map disk cannot be written) beside the
  // logs, so that it survives a restart of fuse-map; on another file system when --map-dir is.
  plan.services.push_back(service(o, "fuse-map", {"--map-dir", map_dir, "--set",
                                                  "map_server.spill_directory=" + path_in(o.out_dir, "map-spill")}));
  // As fuse-run does, the recording's own extrinsic (when it has one) overrides the config's.
  plan.services.push_back(service(o, "fuse-state", {"--trajectory", path_in(o.out_dir, "trajectory.tum"),
                                                    "--calibration-from", o.input, "--set",
                                                    "state.checkpoint_file=" + path_in(o.out_dir, "state.checkpoint")}));
  plan.services.push_back(service(o, "fuse-update", {}));
  if (o.viz) plan.services.push_back(service(o, "fuse-viz", {}));
  std::vector<std::string> ingest{"--input", o.input, "--mode", o.mode};
  if (o.rate) ingest.insert(ingest.end(), {"--rate", number(*o.rate)});
  if (o.mode == "realtime") ingest.insert(ingest.end(), {"--start-wall", microseconds(start_wall)});
  ServiceSpec driver = service(o, "fuse-ingest", ingest);
  driver.exit_zero_is_done = true;
  driver.restart = o.restart && o.mode == "realtime";
  plan.services.push_back(driver);
  return plan;
}

}  // namespace fuse::launch

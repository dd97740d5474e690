// The command lines of one FUSE deployment (DESIGN §2): fuse-map, fuse-state, fuse-update, with
// --viz fuse-viz, then the driver fuse-ingest, each with the shared config and overrides.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "fuse/launch/process_supervisor.hpp"

namespace fuse::launch {

struct LaunchOptions {
  std::string config_file;
  std::string input;                 ///< recording or sequence directory replayed by fuse-ingest
  std::string mode = "lockstep";     ///< lockstep | realtime
  std::optional<double> rate;        ///< realtime rate factor
  std::string out_dir = "fuse_out";  ///< logs/, trajectory.tum, map/ (unless map_dir is set)
  std::string map_dir;               ///< empty: <out_dir>/map
  std::optional<int> domain_id;      ///< --set transport.domain_id=N for every service
  std::string vendor;                ///< non-empty: --set transport.vendor=V for every service
  std::vector<std::string> overrides;  ///< --set key=value for every service, in order
  std::string bin_dir;               ///< where the service binaries are
  bool restart = false;              ///< restart services that die unexpectedly
  bool viz = false;                  ///< also run fuse-viz, the live view (Foxglove WebSocket)
};

struct LaunchPlan {
  std::vector<ServiceSpec> services;  ///< in start order; the last one is the driver
  std::string log_dir;
  std::string trajectory_file;  ///< fuse-state's
  std::string map_dir;          ///< fuse-map's
};

/// The --set overrides every service gets (the options' own, then domain and vendor).
std::vector<std::string> service_overrides(const LaunchOptions& options);

/// The services' command lines. In realtime mode fuse-ingest gets --start-wall start_wall (Unix
/// seconds): a restarted replay then resumes where the clock is instead of at the beginning,
/// which is why only realtime replays are restarted (a lockstep replay would start over).
LaunchPlan make_launch_plan(const LaunchOptions& options, double start_wall);

}  // namespace fuse::launch

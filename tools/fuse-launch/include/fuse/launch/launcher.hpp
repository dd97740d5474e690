// The launcher's run: start the plan's services in order, wait for the driver (the last one) to
// finish, then stop the others, the last started first. A service failing, or a stop request
// (SIGINT/SIGTERM to the launcher), ends the run early with the same ordered stop.
#pragma once

#include <chrono>
#include <functional>
#include <string>
#include <vector>

#include "fuse/launch/launch_plan.hpp"
#include "fuse/launch/process_supervisor.hpp"

namespace fuse::launch {

struct LaunchTiming {
  std::chrono::milliseconds settle{500};         ///< between the services and the driver
  std::chrono::milliseconds stop_timeout{5000};  ///< per service, before SIGKILL
  std::chrono::milliseconds poll_interval{20};
};

struct LaunchOutcome {
  bool success = false;      ///< every service did its part and stopped cleanly (exit 0)
  bool interrupted = false;  ///< stop_requested() ended the run
  std::string failure;       ///< the first reason it is not a success
  std::vector<ServiceReport> reports;  ///< in start order
  std::vector<std::string> losses;     ///< set by the caller: what the run lost although it ran
};

/// Runs the plan under `supervisor` (whose log_dir should be plan.log_dir). stop_requested is
/// polled; true stops everything cleanly. `tick`, when set, runs at every poll.
LaunchOutcome run_launch(const LaunchPlan& plan, ProcessSupervisor& supervisor, const LaunchTiming& timing,
                         const std::function<bool()>& stop_requested, const std::function<void()>& tick = {});

/// One line per service (name, state, last exit, restarts, log file; for a failed one its last
/// error line), then "result: ok", "result: lost: ..." or "result: failed: ...".
std::string summarize(const LaunchOutcome& outcome);

/// The last line of a service log that reports an error ("[error]", "[critical]"), or "".
std::string last_error_line(const std::string& log_path);

}  // namespace fuse::launch

#include "fuse/launch/launcher.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <thread>

#include "fuse/core/logging.hpp"

namespace fuse::launch {

namespace {
enum class Watch { elapsed, driver_done, failed, stop_requested };

/// Polls the supervisor until `until` (or forever), returning early when a service failed, the
/// driver finished, or a stop was requested.
Watch watch(ProcessSupervisor& supervisor, const std::string& driver, const LaunchTiming& timing,
            const std::function<bool()>& stop_requested, const std::function<void()>& tick,
            std::chrono::steady_clock::time_point until) {
  for (;;) {
    supervisor.poll();
    if (tick) tick();
    if (stop_requested()) return Watch::stop_requested;
    for (const auto& name : supervisor.names()) {
      if (supervisor.state(name) == ServiceState::failed) return Watch::failed;
    }
    if (!driver.empty() && supervisor.state(driver) == ServiceState::done) return Watch::driver_done;
    if (std::chrono::steady_clock::now() >= until) return Watch::elapsed;
    std::this_thread::sleep_for(timing.poll_interval);
  }
}

/// Why a service's final report makes the run a failure; empty when it does not.
std::string failure_of(const ServiceReport& r) {
  const std::string exit = r.last_exit ? r.last_exit->describe() : "no exit status";
  if (r.state == ServiceState::failed) {
    const std::string error = last_error_line(r.log_path);
    return r.name + " failed (" + (r.failure.empty() ? exit : r.failure) + ")" + (error.empty() ? "" : ": " + error);
  }
  if (r.state == ServiceState::stopped && r.down_at_stop) return {};  // killed, its restart pending
  if (r.state == ServiceState::stopped && r.escalated) return r.name + " ignored SIGTERM and was killed";
  if (r.state == ServiceState::stopped && r.last_exit && !r.last_exit->success()) {
    return r.name + " did not stop cleanly (" + exit + ")";
  }
  return {};
}
}  // namespace

LaunchOutcome run_launch(const LaunchPlan& plan, ProcessSupervisor& supervisor, const LaunchTiming& timing,
                         const std::function<bool()>& stop_requested, const std::function<void()>& tick) {
  LaunchOutcome out;
  auto log = logger("launch");
  const auto forever = std::chrono::steady_clock::time_point::max();
  const std::string driver = plan.services.empty() ? "" : plan.services.back().name;
  try {
    for (std::size_t i = 0; i + 1 < plan.services.size(); ++i) supervisor.start(plan.services[i]);
    Watch w = watch(supervisor, "", timing, stop_requested, tick, std::chrono::steady_clock::now() + timing.settle);
    if (w == Watch::elapsed && !driver.empty()) {
      supervisor.start(plan.services.back());
      w = watch(supervisor, driver, timing, stop_requested, tick, forever);
    }
    out.interrupted = (w == Watch::stop_requested);
    if (out.interrupted) log->info("stop requested: stopping the services");
    if (w == Watch::driver_done) log->info("{} finished: stopping the services", driver);
  } catch (const std::exception& e) {
    out.failure = e.what();
    log->error("{}", out.failure);
  }
  supervisor.stop_all(timing.stop_timeout);
  for (const auto& name : supervisor.names()) {
    out.reports.push_back(supervisor.report(name));
    if (out.failure.empty()) out.failure = failure_of(out.reports.back());
  }
  const auto names = supervisor.names();
  const bool driver_started = std::find(names.begin(), names.end(), driver) != names.end();
  if (out.failure.empty() && !out.interrupted && (!driver_started || supervisor.state(driver) != ServiceState::done)) {
    out.failure = driver + " did not finish";
  }
  out.success = out.failure.empty();
  return out;
}

std::string summarize(const LaunchOutcome& outcome) {
  std::ostringstream os;
  for (const auto& r : outcome.reports) {
    os << r.name << ": " << to_string(r.state) << ", "
       << (r.down_at_stop ? "down at the end, restart pending (last: " + (r.last_exit ? r.last_exit->describe() : "?") + ")"
                          : (r.last_exit ? r.last_exit->describe() : "running"))
       << (r.escalated ? " after SIGKILL" : "") << ", restarts " << r.restarts << ", log " << r.log_path << "\n";
  }
  if (!outcome.success) {
    os << "result: failed: " << outcome.failure;
  } else if (!outcome.losses.empty()) {
    os << "result: lost: ";
    for (std::size_t i = 0; i < outcome.losses.size(); ++i) os << (i ? "; " : "") << outcome.losses[i];
  } else {
    os << "result: ok";
  }
  os << (outcome.interrupted ? " (interrupted)" : "") << "\n";
  return os.str();
}

std::string last_error_line(const std::string& log_path) {
  std::ifstream log(log_path);
  std::string last;
  for (std::string line; std::getline(log, line);) {
    if (line.find("[error]") != std::string::npos || line.find("[critical]") != std::string::npos) last = line;
  }
  return last;
}

}  // namespace fuse::launch

// fuse-map: the map server (DESIGN §2).
//
//   fuse-map --config FILE [--set key=value]... [--map-dir DIR] [--log-level L]
//
// Serves the persistent map of map_server.directory (--map-dir overrides it): applies the
// observations of map/observation (journal first), publishes map/chunk and map/status, answers
// map/control (fuse-map-ctl) and a heartbeat on health, until SIGINT or SIGTERM. Nothing needs
// saving on the way out: every acknowledged observation is already in the journal (fsync'd
// before it is acknowledged); the observation in hand is finished first. A map directory that
// cannot be written (read-only file system, full disk) is no reason to stop: it serves what it
// loaded, degraded, and tries again (map_server.retry_interval_s). Under systemd (Type=notify,
// notify.hpp) it sends READY=1 once the map is loaded (degraded or not), STATUS= when its state
// changes, WATCHDOG=1 while its worker makes progress, and STOPPING=1 on the way out.
// Exit codes: 0 stopped by a signal, 1 could not start (a map file unreadable, transport),
// 2 usage or config, or the map directory locked by another running fuse-map (a conflict that
// restarting cannot resolve: supervisors do not restart on 2).
#include "fuse/core/logging.hpp"
#include "fuse/service/health.hpp"
#include "fuse/service/notify.hpp"
#include "fuse/service/runtime.hpp"
#include "map_service.hpp"

int main(int argc, char** argv) {
  using namespace fuse;
  service::ServiceArgs args;
  service::SystemConfig config;
  int exit_code = 0;
  const service::ServiceCli cli{
      "fuse-map",
      "The map server of FUSE-SLAM: journals (fsync'd, then acknowledged) and applies the observations of "
      "map/observation, publishes map/chunk and map/status, answers fuse-map-ctl. A map directory that cannot "
      "be written is no reason to stop: it runs degraded and tries again.",
      {{"map-dir", "DIR", "the map directory (snapshot and journal); default map_server.directory"}},
      "Exit codes: 0 stopped by SIGINT or SIGTERM, 1 could not start (a map file unreadable, transport), 2 usage "
      "or config error, or the map directory locked by another running fuse-map."};
  if (!service::start_service(cli, argc, argv, args, config, exit_code)) return exit_code;
  auto log = logger("fuse-map");
  if (args.options.count("map-dir")) {
    if (args.get("map-dir").empty()) {
      log->error("--map-dir needs a directory");
      return 2;
    }
    config.map_server.directory = args.get("map-dir");
  }

  try {
    auto participant = transport::make_participant(config.transport, "fuse-map");
    config.map_server.system_name = config.transport.system_name;
    std::shared_ptr<service::Ros2Output> ros2;
    if (config.ros2.enabled) {
      ros2 = std::make_shared<service::Ros2Output>(*participant, config.ros2, service::Ros2Output::Outputs{false, false, true});
    }
    map_service::MapService map(config.map_server, *participant, ros2, config.ros2.map_period_s);
    service::HealthReporter health(*participant, "fuse-map", config.health.period_s, config.health.instance_window_s, [&] { return map.health(); });
    if (ros2) ros2->attach(health);
    // Start-up complete (map loaded, endpoints created): READY; then the watchdog while the
    // worker that journals and applies observations keeps making progress.
    service::Notifier& notify = service::notifier();
    auto status_line = [&](const service::HealthSnapshot& h) {
      return "serving " + config.map_server.directory +
             (h.state == "degraded" ? " (degraded: " + h.last_error + ")" : "");
    };
    service::HealthSnapshot shown = map.health();
    notify.ready(status_line(shown));
    while (!service::wait_for_stop(notify.wake_interval_s())) {
      if (map.worker_silence_s() < map_service::MapService::kWorkerStuckS) notify.watchdog();
      const service::HealthSnapshot now = map.health();
      if (now.state != shown.state) notify.status(status_line(now));
      shown = now;
    }
    log->info("stop requested");
    notify.stopping("finishing the observation in hand; the journal holds every acknowledged one");
    map.stop();
    health.publish_now();
  } catch (const MapDirectoryLocked& e) {
    log->error("{}: another fuse-map serves this map directory; not starting (exit code 2, not restarted)",
               e.what());
    return 2;
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return 1;
  }
  log->info("stopped: map journal closed");  // the core (and its journal file) went with `map`
  return 0;
}

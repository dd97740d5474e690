// fuse-viz: the live view (docs/architecture.md, "Live view"), an optional fifth process.
//
//   fuse-viz --config FILE [--set key=value]... [--log-level L]
//
// Serves the Foxglove WebSocket protocol (foxglove.websocket.v1) on viz.address:viz.port
// (localhost:8765 by default): the pose at IMU and at scan rate, the transform tree
// world -> imu -> lidar, the deskewed scan and the map in the world frame, the trajectory so far
// and the services' health, in schemas Foxglove's 3D panel draws without setup. Read-only on the
// bus (DDS role viz). Exit codes: 0 stopped by SIGINT or SIGTERM, 1 could not start (the address
// cannot be bound, transport), 2 usage or config.
#include <sys/resource.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>
#include <system_error>

#include "fuse/core/logging.hpp"
#include "fuse/service/health.hpp"
#include "fuse/service/notify.hpp"
#include "fuse/service/runtime.hpp"
#include "viz_service.hpp"

int main(int argc, char** argv) {
  using namespace fuse;
  service::ServiceArgs args;
  service::SystemConfig config;
  int exit_code = 0;
  const service::ServiceCli cli{
      "fuse-viz",
      "The live view of FUSE-SLAM: a Foxglove WebSocket server (foxglove.websocket.v1) with the pose, the transform "
      "tree world -> imu -> lidar, the deskewed scan, the map, the trajectory and the services' health, in schemas "
      "Foxglove's 3D panel draws. Binds viz.address:viz.port (127.0.0.1:8765 by default).",
      {},
      "Exit codes: 0 stopped by SIGINT or SIGTERM, 1 could not start (address in use, transport), 2 usage or config "
      "error."};
  if (!service::start_service(cli, argc, argv, args, config, exit_code)) return exit_code;
  auto log = logger("fuse-viz");
  // A viewer yields the CPU to the estimator (viz.nice). Niceness is per thread on Linux: every
  // thread that exists now (start-up made a signal thread) takes it, and later ones inherit it.
  std::string failed;
  std::error_code no_proc;
  for (const auto& task : std::filesystem::directory_iterator("/proc/self/task", no_proc)) {
    const auto tid = static_cast<id_t>(std::stoul(task.path().filename().string()));
    if (::setpriority(PRIO_PROCESS, tid, config.viz.nice) != 0) failed = std::strerror(errno);
  }
  if (no_proc) failed = "cannot list its threads in /proc/self/task: " + no_proc.message();
  if (!failed.empty()) {
    log->warn("could not lower its priority to niceness {} (viz.nice): {}", config.viz.nice, failed);
  }
  try {
    auto participant = transport::make_participant(config.transport, "fuse-viz");
    viz::VizService viz(config, *participant);
    service::HealthReporter health(*participant, "fuse-viz", config.health.period_s, config.health.instance_window_s,
                                   [&] { return viz.health(); });
    service::Notifier& notify = service::notifier();
    notify.ready("serving ws://" + config.viz.address + ":" + std::to_string(viz.port()));
    while (!service::wait_for_stop(notify.wake_interval_s())) notify.watchdog();
    log->info("stop requested");
    notify.stopping("closing client connections");
    viz.stop();
    health.publish_now();
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return 1;
  }
  log->info("stopped");
  return 0;
}

// fuse-update: LiDAR update against the local map replica (see update_service.hpp).
#include "fuse/core/logging.hpp"
#include "fuse/service/notify.hpp"
#include "fuse/service/runtime.hpp"
#include "update_service.hpp"

int main(int argc, char** argv) {
  using namespace fuse::service;
  ServiceArgs args;
  SystemConfig config;
  int exit_code = 0;
  const ServiceCli cli{
      "fuse-update",
      "LiDAR update of FUSE-SLAM: registers each scan against its replica of the map, sends the correction "
      "to fuse-state and the accepted observation to fuse-map, keeping it until fuse-map acknowledges it.",
      {},
      "Exit codes: 0 stopped by SIGINT or SIGTERM, 1 runtime failure (restarting may help), 2 usage or config error, 4 an input that cannot be read."};
  if (!start_service(cli, argc, argv, args, config, exit_code)) return exit_code;
  auto log = fuse::logger("fuse-update");
  try {
    auto participant = fuse::transport::make_participant(config.transport, "fuse-update");
    UpdateService service(config, *participant);
    log->info("running");
    notifier().ready("endpoints created; building the map replica");  // does not wait for fuse-map
    service.run();
    notifier().stopping();
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return 1;
  }
  log->info("stopped");
  return 0;
}

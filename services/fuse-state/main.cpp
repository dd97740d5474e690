// fuse-state: propagation, state history, query and history RPCs (see state_service.hpp).
#include "fuse/core/logging.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/service/notify.hpp"
#include "fuse/service/runtime.hpp"
#include "state_service.hpp"

int main(int argc, char** argv) {
  using namespace fuse::service;
  ServiceArgs args;
  SystemConfig config;
  int exit_code = 0;
  const ServiceCli cli{
      "fuse-state",
      "IMU propagation, the state history and the query and history RPCs of FUSE-SLAM: takes imu and "
      "update/correction, publishes state/odometry and state/corrected, answers planners' queries. After a "
      "restart it recovers from the newest posterior still held anywhere (docs/architecture.md).",
      {{"trajectory", "FILE", "also write the corrected trajectory (TUM) to FILE"},
       {"calibration-from", "INPUT", "take the LiDAR-IMU extrinsic of a recording or sequence directory"}},
      "Exit codes: 0 stopped by SIGINT or SIGTERM, 1 runtime failure (restarting may help), 2 usage or config error, 4 an input that cannot be read."};
  if (!start_service(cli, argc, argv, args, config, exit_code)) return exit_code;
  auto log = fuse::logger("fuse-state");
  try {
    // As fuse-run: a recording's extrinsic overrides the configured one.
    if (const std::string input = args.get("calibration-from"); !input.empty()) {
      try {
        if (auto T = fuse::io::open_sensor_source(input)->T_imu_lidar()) config.estimator.T_imu_lidar = *T;
      } catch (const fuse::io::InputError& e) {
        log->error("--calibration-from {}: {}", input, e.what());
        return kExitInput;
      }
    }
    auto participant = fuse::transport::make_participant(config.transport, "fuse-state");
    StateService service(config, *participant, args.get("trajectory"));
    log->info("running");
    notifier().ready("endpoints created; recovering, then serving");  // does not wait for the others
    service.run();
    notifier().stopping();
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return 1;
  }
  log->info("stopped");
  return 0;
}

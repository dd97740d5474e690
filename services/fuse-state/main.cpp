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
  if (!start_service("fuse-state", argc, argv, {"trajectory", "calibration-from"}, args, config, exit_code)) return exit_code;
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

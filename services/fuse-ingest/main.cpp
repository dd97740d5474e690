// fuse-ingest: replays a recording, a sequence directory or an Ouster capture, or publishes a
// live Ouster / Livox sensor (see ingest_service.hpp, ingest_input.hpp).
#include <set>

#include "fuse/core/logging.hpp"
#include "fuse/service/notify.hpp"
#include "fuse/service/runtime.hpp"
#include "ingest_service.hpp"

int main(int argc, char** argv) {
  using namespace fuse::service;
  ServiceArgs args;
  SystemConfig config;
  int exit_code = 0;
  const ServiceCli cli{
      "fuse-ingest",
      "Sensor input of FUSE-SLAM: publishes the IMU and LiDAR of a live sensor (Livox Mid-360 or Ouster over "
      "UDP, or a ROS 2 driver's topics) or of a replay (MCAP recording, sequence directory, Ouster pcap or bag) on "
      "DDS.",
      {{"input", "RECORDING", "replay a recording, a sequence directory, an Ouster .pcap or bag"},
       {"ouster-metadata", "FILE.json", "the Ouster sensor's metadata (with a .pcap, bag or --ouster-udp)"},
       {"ouster-udp", "ADDRESS[:LIDAR_PORT:IMU_PORT]", "a live Ouster sensor"},
       {"livox-udp", "ADDRESS[:POINT_PORT:IMU_PORT]", "a live Livox sensor, e.g. 0.0.0.0:56301:56401"},
       {"ros2", "IMU_TOPIC,LIDAR_TOPIC",
        "a ROS 2 driver's topics on the same DDS domain (sensor_msgs/Imu and sensor_msgs/PointCloud2 or "
        "livox_ros_driver2/CustomMsg), e.g. /livox/imu,/livox/lidar"},
       {"ros2-lidar-type", "pointcloud2|livox", "with --ros2: the LiDAR topic's type (default pointcloud2)"},
       {"time-field", "F", "with --ros2: the PointCloud2 per-point time field (t, time, timestamp, offset_time; "
                           "default: the first present)"},
       {"imu-accel-unit", "mps2|g", "with --ros2: the unit of the IMU's acceleration (default mps2)"},
       {"ros2-reliability", "best_effort|reliable",
        "with --ros2: best_effort (default) matches best-effort and reliable drivers; reliable only reliable ones"},
       {"mode", "lockstep|realtime", "replay pace (default ingest.mode)"},
       {"rate", "R", "replay speed factor in (0, 100] (default ingest.rate)"},
       {"start-wall", "UNIX_S", "real-time replay: the wall-clock time of the recording's start"}},
      "Exit codes: 0 stopped by SIGINT or SIGTERM, 1 runtime failure (restarting may help), 2 usage or config error, 4 an input that cannot be read."};
  if (!start_service(cli, argc, argv, args, config, exit_code)) {
    return exit_code;
  }
  auto log = fuse::logger("fuse-ingest");
  IngestOptions options;
  options.mode = args.get("mode", config.ingest.mode);
  constexpr const char* kUsage =
      "usage: fuse-ingest --config FILE (--input RECORDING|SEQDIR | --input FILE.pcap --ouster-metadata FILE.json | "
      "--input OUSTER.bag [--ouster-metadata FILE.json] | "
      "--ouster-udp ADDRESS[:LIDAR_PORT:IMU_PORT] --ouster-metadata FILE.json | --livox-udp ADDRESS[:POINT_PORT:IMU_PORT] | "
      "--ros2 IMU_TOPIC,LIDAR_TOPIC [--ros2-lidar-type pointcloud2|livox] [--time-field F] [--imu-accel-unit mps2|g] "
      "[--ros2-reliability best_effort|reliable]) "
      "[--mode lockstep|realtime] [--rate R in (0,100]] [--start-wall UNIX_S]";
  try {
    options.input = parse_ingest_input(args);
  } catch (const std::invalid_argument& e) {
    log->error("{}", e.what());
    log->error("{}", kUsage);
    return 2;
  }
  try {
    options.rate = std::stod(args.get("rate", std::to_string(config.ingest.rate)));
    if (!args.get("start-wall").empty()) options.start_wall = std::stod(args.get("start-wall"));
  } catch (const std::exception&) {
    log->error("--rate and --start-wall take numbers");
    return 2;
  }
  if ((options.mode != "lockstep" && options.mode != "realtime") || !(options.rate > 0.0 && options.rate <= 100.0)) {
    log->error("{}", kUsage);
    return 2;
  }
  try {
    auto participant = fuse::transport::make_participant(config.transport, "fuse-ingest");
    IngestService service(config, *participant, options);
    notifier().ready("input open, endpoints created");  // does not wait for the pipeline
    const int code = service.run();
    notifier().stopping();
    return code;
  } catch (const fuse::io::InputError& e) {
    log->error("cannot open input: {}", e.what());
    return kExitInput;
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return 1;
  }
}

// What fuse-ingest reads, from its command line:
//   --input PATH                                   MCAP recording or sequence directory (replay)
//   --input FILE.pcap --ouster-metadata FILE.json  Ouster capture (replay, like a recording)
//   --input FILE.bag [--ouster-metadata FILE.json] ouster_ros packets in a ROS 1 bag (replay);
//                                                  the metadata from the bag unless given
//   --ouster-udp ADDRESS[:LIDAR_PORT:IMU_PORT] --ouster-metadata FILE.json
//                                                  live Ouster sensor; ports from the metadata
//                                                  unless given (0: any free port)
//   --livox-udp ADDRESS[:POINT_PORT:IMU_PORT]      live Livox Mid-360 (SDK2 protocol; default
//                                                  ports 56301 / 56401)
//   --ros2 IMU_TOPIC,LIDAR_TOPIC [--ros2-lidar-type pointcloud2|livox] [--time-field F]
//          [--imu-accel-unit mps2|g] [--ros2-reliability best_effort|reliable]
//                                                  a ROS 2 driver's topics on the same DDS domain
// Live inputs publish each event as it arrives and end only on SIGTERM/SIGINT.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "fuse/io/sensor_source.hpp"
#include "fuse/service/runtime.hpp"
#include "fuse/service/system_config.hpp"
#include "ros2_source.hpp"

namespace fuse::service {

struct IngestInput {
  enum class Kind { kRecording, kOusterPcap, kOusterBag, kOusterUdp, kLivoxUdp, kRos2 };
  Kind kind = Kind::kRecording;
  std::string path;             ///< recording, sequence directory or pcap
  std::string ouster_metadata;  ///< Ouster inputs
  std::string address;          ///< live inputs: local IPv4 address to bind
  std::optional<std::uint16_t> port_a, port_b;  ///< live inputs: lidar/point and IMU ports
  Ros2InputConfig ros2;         ///< --ros2
  bool live() const { return kind == Kind::kOusterUdp || kind == Kind::kLivoxUdp || kind == Kind::kRos2; }
};

/// Reads the input options; throws std::invalid_argument naming what is wrong or missing.
IngestInput parse_ingest_input(const ServiceArgs& args);

/// Opens the input (live sources poll stop_requested() so SIGTERM ends them); a recording's streams
/// are time-checked with `clock` (estimator.clock). `participant` is needed for --ros2 (its
/// readers join the service's own participant). Throws io::InputError when it cannot be opened.
std::unique_ptr<io::SensorSource> open_ingest_input(const IngestInput& input, const TimeGateConfig& clock = {},
                                                    transport::Participant* participant = nullptr);

}  // namespace fuse::service

#include "ingest_input.hpp"

#include <stdexcept>

#include "fuse/io/livox_udp_source.hpp"
#include "fuse/io/ouster_pcap_source.hpp"
#include "fuse/io/ouster_udp_source.hpp"
#include "ouster_bag_source.hpp"

namespace fuse::service {

namespace {

constexpr double kStandardGravity = 9.80665;  // m/s^2 per g, for drivers that write g

std::uint16_t port(const std::string& text, const std::string& option) {
  std::size_t used = 0;
  unsigned long v = 0;
  try {
    v = std::stoul(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || v > 65535) {
    throw std::invalid_argument("--" + option + ": '" + text + "' is not a UDP port (0..65535)");
  }
  return static_cast<std::uint16_t>(v);
}

/// ADDRESS or ADDRESS:PORT_A:PORT_B.
void parse_endpoint(const std::string& value, const std::string& option, IngestInput& in) {
  const auto first = value.find(':');
  if (first == std::string::npos) {
    in.address = value;
  } else {
    const auto second = value.find(':', first + 1);
    if (second == std::string::npos || value.find(':', second + 1) != std::string::npos) {
      throw std::invalid_argument("--" + option + " takes ADDRESS or ADDRESS:PORT:IMU_PORT, not '" + value + "'");
    }
    in.address = value.substr(0, first);
    in.port_a = port(value.substr(first + 1, second - first - 1), option);
    in.port_b = port(value.substr(second + 1), option);
  }
  if (in.address.empty()) throw std::invalid_argument("--" + option + ": the local address is empty (0.0.0.0 for all)");
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

IngestInput parse_ingest_input(const ServiceArgs& args) {
  IngestInput in;
  const std::string input = args.get("input"), ouster_udp = args.get("ouster-udp"), livox_udp = args.get("livox-udp");
  const std::string ros2 = args.get("ros2");
  in.ouster_metadata = args.get("ouster-metadata");
  const int given = !input.empty() + !ouster_udp.empty() + !livox_udp.empty() + !ros2.empty();
  if (given != 1) throw std::invalid_argument("give exactly one of --input, --ouster-udp, --livox-udp, --ros2");
  const bool ros2_options = !args.get("ros2-lidar-type").empty() || !args.get("time-field").empty() ||
                            !args.get("imu-accel-unit").empty() || !args.get("ros2-reliability").empty();
  if (ros2_options && ros2.empty()) {
    throw std::invalid_argument("--ros2-lidar-type, --time-field, --imu-accel-unit and --ros2-reliability go with --ros2");
  }
  if (!ros2.empty()) {
    if (!in.ouster_metadata.empty()) throw std::invalid_argument("--ouster-metadata does not go with --ros2");
    in.kind = IngestInput::Kind::kRos2;
    parse_ros2_topics(ros2, in.ros2);
    in.ros2.lidar_type = args.get("ros2-lidar-type", "pointcloud2");
    in.ros2.time_field = args.get("time-field");
    const std::string unit = args.get("imu-accel-unit", "mps2");
    if (unit != "mps2" && unit != "g") throw std::invalid_argument("--imu-accel-unit '" + unit + "': mps2 or g");
    in.ros2.accel_scale = unit == "g" ? kStandardGravity : 1.0;
    const std::string reliability = args.get("ros2-reliability", "best_effort");
    if (reliability != "best_effort" && reliability != "reliable") {
      throw std::invalid_argument("--ros2-reliability '" + reliability + "': best_effort or reliable");
    }
    in.ros2.reliable = reliability == "reliable";
    in.ros2.validate();
    return in;
  }
  if (!input.empty()) {
    in.path = input;
    if (ends_with(input, ".bag")) {
      in.kind = IngestInput::Kind::kOusterBag;  // metadata from the bag unless given
    } else if (ends_with(input, ".pcap")) {
      if (in.ouster_metadata.empty()) {
        throw std::invalid_argument("--input " + input + " is a pcap capture: --ouster-metadata FILE.json is needed");
      }
      in.kind = IngestInput::Kind::kOusterPcap;
    } else if (!in.ouster_metadata.empty()) {
      throw std::invalid_argument("--ouster-metadata goes with a .pcap or .bag --input or --ouster-udp");
    }
  } else if (!ouster_udp.empty()) {
    if (in.ouster_metadata.empty()) throw std::invalid_argument("--ouster-udp needs --ouster-metadata FILE.json");
    in.kind = IngestInput::Kind::kOusterUdp;
    parse_endpoint(ouster_udp, "ouster-udp", in);
  } else {
    if (!in.ouster_metadata.empty()) throw std::invalid_argument("--ouster-metadata does not go with --livox-udp");
    in.kind = IngestInput::Kind::kLivoxUdp;
    parse_endpoint(livox_udp, "livox-udp", in);
  }
  return in;
}

std::unique_ptr<io::SensorSource> open_ingest_input(const IngestInput& in, const TimeGateConfig& clock,
                                                    transport::Participant* participant) {
  switch (in.kind) {
    case IngestInput::Kind::kRos2: {
      if (participant == nullptr) throw std::logic_error("--ros2 needs the service's DDS participant");
      Ros2InputConfig c = in.ros2;
      c.should_stop = [] { return stop_requested(); };
      return std::make_unique<Ros2Source>(*participant, c, clock);
    }
    case IngestInput::Kind::kOusterPcap:
      return std::make_unique<io::OusterPcapSource>(io::OusterPcapConfig{in.path, in.ouster_metadata, {}, {}});
    case IngestInput::Kind::kOusterBag:
      return std::make_unique<OusterBagSource>(in.path, in.ouster_metadata);
    case IngestInput::Kind::kOusterUdp: {
      io::OusterUdpConfig c;
      c.metadata = in.ouster_metadata;
      c.address = in.address;
      c.lidar_port = in.port_a;
      c.imu_port = in.port_b;
      c.should_stop = [] { return stop_requested(); };
      return std::make_unique<io::OusterUdpSource>(c);
    }
    case IngestInput::Kind::kLivoxUdp: {
      io::LivoxUdpConfig c;
      c.address = in.address;
      if (in.port_a) c.point_port = *in.port_a;
      if (in.port_b) c.imu_port = *in.port_b;
      c.should_stop = [] { return stop_requested(); };
      return std::make_unique<io::LivoxUdpSource>(c);
    }
    case IngestInput::Kind::kRecording:
      break;
  }
  return io::open_sensor_source(in.path, clock);
}

}  // namespace fuse::service

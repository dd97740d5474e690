// fuse-map-ctl: controls the running map server through its map/control service.
//
//   fuse-map-ctl [--config FILE] [--set key=value]... [--domain N] [--vendor V] [--deadline-ms N]
//                [--json] (--mode mapping|localization | save [NAME] | load NAME [--other-system] | stats
//                          | set-pose X Y Z YAW_DEG [--std-xy M] [--std-yaw DEG] [--wait S] [--time T])
//                (--help; --version)
//
// Prints the map's state after the command (or one JSON object, errors included); set-pose prints
// the estimator's verdict on the pose (served by fuse-update, which holds the map and the search).
// Exit codes: 0 done (set-pose: accepted or corrected), 2 usage or config, 3 error reply (set-pose:
// refused), 4 no server answered before the deadline, 5 set-pose still being checked after --wait.
#include <algorithm>
#include <chrono>
#include <iostream>

#include "arguments.hpp"
#include "fuse/core/logging.hpp"
#include "fuse/transport/rpc.hpp"
#include "output.hpp"

namespace {
constexpr int kExitDone = 0, kExitUsage = 2, kExitErrorReply = 3, kExitUnavailable = 4, kExitPending = 5;
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

fuse_msgs::MapControlRequest make_request(const fuse::map_ctl::Arguments& args, std::string& name) {
  using fuse::map_ctl::Command;
  fuse_msgs::MapControlRequest req;
  switch (args.command) {
    case Command::kSetMode:
      name = "mode";
      req.command(fuse_msgs::MAP_SET_MODE);
      req.mode(args.mode);
      break;
    case Command::kSave:
      name = "save";
      req.command(fuse_msgs::MAP_SAVE);
      req.path(args.file);
      break;
    case Command::kLoad:
      name = "load";
      req.command(fuse_msgs::MAP_LOAD);
      req.path(args.file);
      req.other_system(args.other_system);
      break;
    default:
      name = "stats";
      req.command(fuse_msgs::MAP_STATS);
  }
  return req;
}
int set_pose(const fuse::map_ctl::Arguments& args, const fuse::transport::TransportConfig& transport) {
  using namespace fuse::map_ctl;
  using Client = fuse::transport::RpcClient<fuse_msgs::SetPoseRequest, fuse_msgs::SetPoseReply>;
  fuse_msgs::SetPoseRequest req;
  req.position().x(args.pose[0]);
  req.position().y(args.pose[1]);
  req.position().z(args.pose[2]);
  req.yaw(args.pose[3] * kDegToRad);
  req.std_xy(args.std_xy);
  req.std_yaw(args.std_yaw * kDegToRad);
  req.wait_s(args.wait_s);
  req.t(args.time);
  // The server answers after at most wait_s: the call's deadline covers it.
  const int deadline_ms = std::max(args.deadline_ms, static_cast<int>(args.wait_s * 1000.0) + 5000);
  try {
    auto participant = fuse::transport::make_participant(transport, "fuse-map-ctl");
    Client client(*participant, fuse::transport::services::kSetPose);
    const Client::Result result = client.call(req, std::chrono::milliseconds(deadline_ms));
    if (args.json) {
      std::cout << format_json(result.status, result.message, result.reply);
    } else if (result.ok()) {
      std::cout << format_text(result.reply);
    }
    if (result.ok()) {
      switch (result.reply.result()) {
        case fuse_msgs::SET_POSE_ACCEPTED:
        case fuse_msgs::SET_POSE_CORRECTED: return kExitDone;
        case fuse_msgs::SET_POSE_PENDING: return kExitPending;
        default: return kExitErrorReply;
      }
    }
    if (!args.json) std::cerr << "fuse-map-ctl: " << status_name(result.status) << ": " << result.message << "\n";
    if (result.status == fuse_msgs::RPC_UNAVAILABLE) {
      if (!args.json) {
        std::cerr << "fuse-map-ctl: no fuse-update answered on domain " << transport.domain_id << " ("
                  << transport.vendor << ") within " << deadline_ms << " ms\n";
      }
      return kExitUnavailable;
    }
    return kExitErrorReply;
  } catch (const std::exception& e) {
    std::cerr << "fuse-map-ctl: " << e.what() << "\n";
    return kExitUnavailable;
  }
}
}  // namespace

int main(int argc, char** argv) {
  using namespace fuse::map_ctl;
  using Client = fuse::transport::RpcClient<fuse_msgs::MapControlRequest, fuse_msgs::MapControlReply>;
  Arguments args;
  fuse::transport::TransportConfig transport;
  if (const std::optional<int> code = parse_arguments(argc, argv, args)) return *code;
  try {
    transport = load_transport_config(args.config_file, args.overrides);
  } catch (const std::exception& e) {
    std::cerr << "fuse-map-ctl: config error: " << e.what() << "\n";
    return kExitUsage;
  }
  fuse::set_log_level("warn");  // stdout is the reply; keep stderr for problems
  if (args.command == Command::kSetPose) return set_pose(args, transport);

  std::string command;
  const fuse_msgs::MapControlRequest request = make_request(args, command);
  try {
    auto participant = fuse::transport::make_participant(transport, "fuse-map-ctl");
    Client client(*participant, fuse::transport::services::kMapControl);
    const Client::Result result = client.call(request, std::chrono::milliseconds(args.deadline_ms));
    if (args.json) {
      std::cout << format_json(command, result.status, result.message, result.reply);
    } else if (result.ok()) {
      std::cout << format_text(result.reply);
    }
    if (result.ok()) return kExitDone;
    if (!args.json) std::cerr << "fuse-map-ctl: " << status_name(result.status) << ": " << result.message << "\n";
    if (result.status == fuse_msgs::RPC_UNAVAILABLE) {
      if (!args.json) {
        std::cerr << "fuse-map-ctl: no fuse-map answered on domain " << transport.domain_id << " ("
                  << transport.vendor << ") within " << args.deadline_ms << " ms\n";
      }
      return kExitUnavailable;
    }
    return kExitErrorReply;
  } catch (const std::exception& e) {
    std::cerr << "fuse-map-ctl: " << e.what() << "\n";
    return kExitUnavailable;
  }
}

// fuse-map-ctl: controls the running map server through its map/control service.
//
//   fuse-map-ctl [--config FILE] [--set key=value]... [--domain N] [--vendor V] [--deadline-ms N]
//                [--json] (--mode mapping|localization | save [NAME] | load NAME [--other-system] | stats)
//                (--help; --version)
//
// Prints the map's state after the command (or one JSON object, errors included).
// Exit codes: 0 done, 2 usage or config, 3 error reply, 4 no server answered before the deadline.
#include <chrono>
#include <iostream>

#include "arguments.hpp"
#include "fuse/core/logging.hpp"
#include "fuse/transport/rpc.hpp"
#include "output.hpp"

namespace {
constexpr int kExitDone = 0, kExitUsage = 2, kExitErrorReply = 3, kExitUnavailable = 4;

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

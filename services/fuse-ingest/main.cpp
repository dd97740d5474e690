// fuse-ingest: replays a recording or a sequence directory (see ingest_service.hpp).
#include "fuse/core/logging.hpp"
#include "fuse/service/runtime.hpp"
#include "ingest_service.hpp"

int main(int argc, char** argv) {
  using namespace fuse::service;
  ServiceArgs args;
  SystemConfig config;
  int exit_code = 0;
  if (!start_service("fuse-ingest", argc, argv, {"input", "mode", "rate", "start-wall"}, args, config, exit_code)) {
    return exit_code;
  }
  auto log = fuse::logger("fuse-ingest");
  IngestOptions options;
  options.input = args.get("input");
  options.mode = args.get("mode", config.ingest.mode);
  try {
    options.rate = std::stod(args.get("rate", std::to_string(config.ingest.rate)));
    if (!args.get("start-wall").empty()) options.start_wall = std::stod(args.get("start-wall"));
  } catch (const std::exception&) {
    log->error("--rate and --start-wall take numbers");
    return 2;
  }
  if (options.input.empty() || (options.mode != "lockstep" && options.mode != "realtime") ||
      !(options.rate > 0.0 && options.rate <= 100.0)) {
    log->error("usage: fuse-ingest --config FILE --input PATH [--mode lockstep|realtime] [--rate R in (0,100]] [--start-wall UNIX_S]");
    return 2;
  }
  try {
    auto participant = fuse::transport::make_participant(config.transport, "fuse-ingest");
    IngestService service(config, *participant, options);
    return service.run();
  } catch (const fuse::io::InputError& e) {
    log->error("cannot open input: {}", e.what());
    return 1;
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return 1;
  }
}

// fuse-query: asks the running estimator for the state at a time.
//
//   fuse-query [--time T [--clock C] | --latest] [--json] [--deadline-ms N] [--config FILE] [--set key=value]...
//              [--domain N] [--vendor V]        (--help lists them; --version)
//
// Prints the pose, velocity, covariance diagonals, time and status (or one JSON object).
// Exit codes: 0 a pose to steer by, 2 usage or config, 3 error reply (out of range, not tracking,
// not ready, ...), 4 unavailable.
#include <iostream>
#include <string>
#include <vector>

#include "arguments.hpp"
#include "client_config.hpp"
#include "fuse/query/client.hpp"
#include "output.hpp"

namespace {
constexpr int kExitAnswered = 0, kExitUsage = 2, kExitErrorReply = 3, kExitUnavailable = 4;

int exit_code(fuse::query::Error error) {
  switch (error) {
    case fuse::query::Error::ok: return kExitAnswered;
    case fuse::query::Error::unavailable: return kExitUnavailable;
    default: return kExitErrorReply;
  }
}

void print(const fuse::query::Result& result, bool json) {
  if (json) {
    std::cout << fuse::query_tool::format_json(result);
  } else if (result.ok()) {
    std::cout << fuse::query_tool::format_text(result);
  } else {
    std::cerr << "fuse-query: " << fuse::query::to_string(result.error) << ": " << result.message << "\n";
    if (result.error == fuse::query::Error::out_of_range || result.error == fuse::query::Error::not_tracking) {
      std::cerr << fuse::query_tool::format_text(result);  // the best guess, with its status
    }
  }
}
}  // namespace

int main(int argc, char** argv) {
  using namespace fuse::query_tool;
  Arguments args;
  fuse::query::ClientOptions options;
  if (const std::optional<int> code = parse_arguments(argc, argv, args)) return *code;
  try {
    options = load_client_options(args.config_file, args.overrides);
    options.deadline_ms = args.deadline_ms;
  } catch (const std::exception& e) {
    std::cerr << "fuse-query: config error: " << e.what() << "\n";
    return kExitUsage;
  }
  try {
    fuse::query::Client client(options);
    const fuse::query::Result result = args.latest ? client.latest() : client.at(args.time, args.clock);
    print(result, args.json);
    return exit_code(result.error);
  } catch (const std::invalid_argument& e) {
    std::cerr << "fuse-query: config error: " << e.what() << "\n";
    return kExitUsage;
  } catch (const std::exception& e) {
    std::cerr << "fuse-query: transport: " << e.what() << "\n";
    return kExitUnavailable;
  }
}

#include "arguments.hpp"

#include <cerrno>
#include <cstdlib>
#include <stdexcept>

#include "fuse/cli/cli.hpp"

namespace fuse::query_tool {

namespace {
double parse_double(const std::string& name, const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE) {
    throw std::invalid_argument(name + ": '" + text + "' is not a number");
  }
  return v;  // non-finite values pass: the client refuses them as a bad request
}

int parse_positive_int(const std::string& name, const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || v <= 0 || v > 3'600'000) {
    throw std::invalid_argument(name + ": '" + text + "' is not a positive number of milliseconds");
  }
  return static_cast<int>(v);
}
}  // namespace

std::optional<int> parse_arguments(int argc, char** argv, Arguments& a) {
  const auto app = cli::make_app(
      "fuse-query",
      "Asks fuse-state for the estimate at time T (seconds, sensor clock unless --clock says otherwise) or the "
      "latest one: pose, velocity, angular velocity, covariance, status, frames and the host clock mapping.",
      "Exit codes: 0 a pose to steer by, 2 usage or config, 3 an answer that is not one (outside the history, "
      "relocalizing, lost, not ready, error reply), 4 no reply (unavailable).");
  std::string time;
  std::string deadline;
  std::string clock = "sensor";
  app->add_option("--time", time, "the time to ask for (seconds on --clock)")->type_name("T");
  app->add_option("--clock", clock,
                  "the clock of --time: sensor (the default; every estimate's t), realtime (the host's UNIX time) "
                  "or monotonic (the host's CLOCK_MONOTONIC, on fuse-state's machine)")
      ->type_name("C")
      ->check(CLI::IsMember({"sensor", "realtime", "monotonic"}));
  app->add_flag("--latest", "the latest estimate (the default)");
  app->add_flag("--json", a.json, "print one JSON object");
  app->add_option("--deadline-ms", deadline, "wait at most N ms for the reply (default 1000)")->type_name("N");
  app->add_option("--config", a.config_file, "a FUSE config; only its transport: section is read")->type_name("FILE");
  const cli::TransportFlags transport(*app);
  if (const std::optional<int> code = cli::parse(*app, argc, argv)) return code;
  try {
    if (app->count("--time") > 0) {
      if (app->count("--latest") > 0) return cli::usage_error(*app, "--time and --latest exclude each other");
      a.time = parse_double("--time", time);
      a.latest = false;
    } else if (app->count("--clock") > 0) {
      return cli::usage_error(*app, "--clock applies to --time only");
    }
    a.clock = clock == "realtime"    ? query::Clock::host_realtime
              : clock == "monotonic" ? query::Clock::host_monotonic
                                     : query::Clock::sensor;
    if (app->count("--deadline-ms") > 0) a.deadline_ms = parse_positive_int("--deadline-ms", deadline);
  } catch (const std::invalid_argument& e) {
    return cli::usage_error(*app, e.what());
  }
  a.overrides = transport.overrides();
  return std::nullopt;
}

}  // namespace fuse::query_tool

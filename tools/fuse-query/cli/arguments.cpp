#include "arguments.hpp"

#include <cerrno>
#include <cstdlib>

namespace fuse::query_tool {

namespace {
double parse_double(const std::string& name, const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE) {
    throw ArgumentError(name + ": '" + text + "' is not a number");
  }
  return v;  // non-finite values pass: the client refuses them as a bad request
}

int parse_positive_int(const std::string& name, const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || v <= 0 || v > 3'600'000) {
    throw ArgumentError(name + ": '" + text + "' is not a positive number of milliseconds");
  }
  return static_cast<int>(v);
}
}  // namespace

Arguments parse_arguments(const std::vector<std::string>& args) {
  Arguments a;
  bool time_given = false, latest_given = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    auto value = [&]() -> const std::string& {
      if (i + 1 >= args.size()) throw ArgumentError(arg + " needs a value");
      return args[++i];
    };
    if (arg == "--help" || arg == "-h") {
      a.help = true;
    } else if (arg == "--time") {
      a.time = parse_double(arg, value());
      a.latest = false;
      time_given = true;
    } else if (arg == "--latest") {
      latest_given = true;
    } else if (arg == "--json") {
      a.json = true;
    } else if (arg == "--deadline-ms") {
      a.deadline_ms = parse_positive_int(arg, value());
    } else if (arg == "--config") {
      a.config_file = value();
    } else if (arg == "--set") {
      a.overrides.push_back(value());
    } else {
      throw ArgumentError("unknown argument '" + arg + "'");
    }
  }
  if (time_given && latest_given) throw ArgumentError("--time and --latest exclude each other");
  return a;
}

std::string usage() {
  return "usage: fuse-query [--time T | --latest] [--json] [--deadline-ms N] [--config FILE] [--set key=value]...\n"
         "  Asks fuse-state for the estimate at time T (seconds, sensor clock) or the latest one.\n"
         "  --config: a FUSE config; only its transport: section is read (vendor, domain_id, ...)\n"
         "  --set:    override a config value, e.g. --set transport.domain_id=7\n"
         "  --json:   print one JSON object\n"
         "  exit codes: 0 answered (any status), 2 usage or config, 3 error reply, 4 no reply (unavailable)\n";
}

}  // namespace fuse::query_tool

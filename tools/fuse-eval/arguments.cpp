// Command-line parsing of fuse-eval: every value is checked before anything is read.
#include "arguments.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace fuse::eval_tool {
namespace {

/// A finite number or ArgumentError naming the option.
double parse_number(const std::string& option, const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end == text.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(value)) {
    throw ArgumentError(option + ": '" + text + "' is not a finite number");
  }
  return value;
}

/// The value after an option, or ArgumentError when the command line ends.
const std::string& value_of(const std::vector<std::string>& args, std::size_t& i) {
  if (i + 1 >= args.size()) throw ArgumentError(args[i] + " needs a value");
  return args[++i];
}

}  // namespace

std::string usage() {
  return "usage: fuse-eval --gt GT --est EST [--format tum|kitti] [--delta M] [--t-max-diff S]\n"
         "                 [--align se3|sim3|none] [--json]\n"
         "  --gt FILE          reference (ground truth) trajectory\n"
         "  --est FILE         estimated trajectory\n"
         "  --format F         tum (default; matched by timestamp) or kitti (matched by index)\n"
         "  --delta M          RPE delta in metres of reference path (default 1.0)\n"
         "  --t-max-diff S     largest timestamp difference of a match in s (default 0.01)\n"
         "  --align A          ATE alignment: se3 (default, evo_ape -a), sim3 (-a -s), none\n"
         "  --json             print one JSON object instead of 'name: value' lines\n"
         "Exit codes: 0 success, 2 bad arguments, unreadable files or no evaluation possible.\n";
}

Arguments parse_arguments(const std::vector<std::string>& args) {
  Arguments a;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    try {
      if (arg == "--help" || arg == "-h") {
        a.help = true;
      } else if (arg == "--gt") {
        a.gt_path = value_of(args, i);
      } else if (arg == "--est") {
        a.est_path = value_of(args, i);
      } else if (arg == "--format") {
        a.format = eval::parse_trajectory_format(value_of(args, i));
      } else if (arg == "--delta") {
        a.config.rpe_delta_m = parse_number(arg, value_of(args, i));
      } else if (arg == "--t-max-diff") {
        a.config.max_time_difference = parse_number(arg, value_of(args, i));
      } else if (arg == "--align") {
        a.config.alignment = eval::parse_alignment_mode(value_of(args, i));
      } else if (arg == "--json") {
        a.json = true;
      } else {
        throw ArgumentError("unknown argument '" + arg + "'");
      }
    } catch (const std::invalid_argument& e) {
      throw ArgumentError(arg + ": " + e.what());
    }
  }
  if (a.help) return a;
  if (a.gt_path.empty()) throw ArgumentError("--gt is required");
  if (a.est_path.empty()) throw ArgumentError("--est is required");
  a.config.association =
      a.format == eval::TrajectoryFormat::kKitti ? eval::AssociationMode::kIndex : eval::AssociationMode::kTimestamp;
  try {
    a.config.validate();
  } catch (const std::invalid_argument& e) {
    throw ArgumentError(e.what());
  }
  return a;
}

}  // namespace fuse::eval_tool

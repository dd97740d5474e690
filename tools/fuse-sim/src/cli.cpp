#include "fuse/sim/cli.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <set>

#include "fuse/sim/lidar_pattern.hpp"
#include "fuse/sim/scenario.hpp"

namespace fuse::sim {

namespace {

constexpr double kMaxDurationS = 1e5;  // sanity bound for --duration
constexpr std::uint64_t kMaxLaps = 100;  // sanity bound for --laps
constexpr double kMinDurationS = 0.1;  // one LiDAR frame

std::uint64_t parse_u64(const std::string& option, const std::string& text) {
  if (text.empty() || !std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; }))
    throw CliError(option + ": expected a non-negative integer, got '" + text + "'");
  errno = 0;
  char* end = nullptr;
  const unsigned long long v = std::strtoull(text.c_str(), &end, 10);
  if (errno == ERANGE || *end != '\0') throw CliError(option + ": '" + text + "' is out of range (64-bit)");
  return static_cast<std::uint64_t>(v);
}

double parse_duration(const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end == text.c_str() || *end != '\0' || errno == ERANGE)
    throw CliError("--duration: expected a number of seconds, got '" + text + "'");
  if (!std::isfinite(v) || v < kMinDurationS || v > kMaxDurationS)
    throw CliError("--duration: must be between 0.1 s (one LiDAR frame) and " +
                   std::to_string(static_cast<int>(kMaxDurationS)) + " s, got '" + text + "'");
  return v;
}

}  // namespace

std::string usage() {
  return "usage: fuse-sim --scenario NAME --seed N [--world-seed M] [--duration S] [--laps N]\n"
         "                [--lidar mid360|spinning32] [--format mcap|seqdir] --out DIR\n"
         "\n"
         "Simulates a LiDAR + IMU sequence with exact ground truth.\n"
         "  --scenario NAME   corridor | stairs | room | campus\n"
         "  --seed N          noise and motion variations (non-negative integer)\n"
         "  --world-seed M    world layout (default: N)\n"
         "  --duration S      cut the scenario short after S seconds\n"
         "  --laps N          corridor: walk round the loop N times (default 1; e.g. a soak test)\n"
         "  --lidar MODEL     mid360 (default) or spinning32\n"
         "  --format F        mcap (DIR/recording.mcap, default) or seqdir (sequence directory in DIR)\n"
         "  --out DIR         output directory (created if missing); also gets groundtruth.tum\n"
         "                    (true T_world_imu at 200 Hz) and scenario.yaml (all parameters)\n"
         "  --help            this text\n";
}

CliCommand parse_cli(const std::vector<std::string>& args) {
  CliCommand cmd;
  std::set<std::string> seen;
  bool world_seed_given = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--help" || a == "-h") {
      cmd.help = true;
      return cmd;
    }
    static const std::set<std::string> kValued = {"--scenario", "--seed",   "--world-seed", "--duration",
                                                  "--lidar",    "--format", "--out",        "--laps"};
    if (!kValued.count(a)) throw CliError("unknown argument '" + a + "'");
    if (!seen.insert(a).second) throw CliError(a + " given more than once");
    if (i + 1 >= args.size()) throw CliError(a + " needs a value");
    const std::string& v = args[++i];
    if (a == "--scenario") {
      const auto& names = scenario_names();
      if (std::find(names.begin(), names.end(), v) == names.end())
        throw CliError("--scenario: unknown scenario '" + v + "' (expected corridor, stairs, room or campus)");
      cmd.options.scenario = v;
    } else if (a == "--seed") {
      cmd.options.seed = parse_u64(a, v);
    } else if (a == "--world-seed") {
      cmd.options.world_seed = parse_u64(a, v);
      world_seed_given = true;
    } else if (a == "--duration") {
      cmd.options.duration_s = parse_duration(v);
    } else if (a == "--laps") {
      const std::uint64_t laps = parse_u64(a, v);
      if (laps < 1 || laps > kMaxLaps) throw CliError("--laps: must be between 1 and " + std::to_string(kMaxLaps));
      cmd.options.laps = static_cast<int>(laps);
    } else if (a == "--lidar") {
      if (v != "mid360" && v != "spinning32")
        throw CliError("--lidar: unknown model '" + v + "' (expected mid360 or spinning32)");
      cmd.options.lidar = v;
    } else if (a == "--format") {
      if (v == "mcap")
        cmd.options.format = OutputFormat::kMcap;
      else if (v == "seqdir")
        cmd.options.format = OutputFormat::kSeqdir;
      else
        throw CliError("--format: unknown format '" + v + "' (expected mcap or seqdir)");
    } else {  // --out
      if (v.empty()) throw CliError("--out: empty directory name");
      cmd.options.out_dir = v;
    }
  }
  if (cmd.options.scenario.empty()) throw CliError("missing --scenario");
  if (!seen.count("--seed")) throw CliError("missing --seed");
  if (cmd.options.out_dir.empty()) throw CliError("missing --out");
  if (!world_seed_given) cmd.options.world_seed = cmd.options.seed;
  if (cmd.options.laps > 1 && cmd.options.scenario != "corridor") {
    throw CliError("--laps: only the corridor's path is a loop");
  }
  return cmd;
}

}  // namespace fuse::sim

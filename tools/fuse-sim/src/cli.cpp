// Command-line parsing of fuse-sim: CLI11 reads the options as text, then every value is checked
// here with a message naming its flag (the checks and messages of the tool's first parser).
#include "fuse/sim/cli.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "fuse/cli/cli.hpp"
#include "fuse/sim/lidar_pattern.hpp"
#include "fuse/sim/scenario.hpp"

namespace fuse::sim {

namespace {

constexpr double kMaxDurationS = 1e5;    // sanity bound for --duration
constexpr std::uint64_t kMaxLaps = 100;  // sanity bound for --laps
constexpr std::uint64_t kMaxStops = 100;  // sanity bound for --stops (the drive has fewer corners)
constexpr double kMinDurationS = 0.1;    // one LiDAR frame
constexpr double kMaxImuTimeOffsetS = 1.0;  // sanity bound for --imu-time-offset (real offsets: ms)
constexpr double kMaxClassifyToleranceM = 10.0;  // sanity bound for --classify-tolerance

/// A value that does not check; parse_arguments prints it as a usage error (exit code 2).
class BadValue : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The options as typed: CLI11 stores the text, the checks below turn it into SimOptions.
struct Given {
  std::string scenario, seed, world_seed, duration, laps, start_at, lidar, format, out, imu_time_offset;
  std::string traffic, classify_map, classify_tolerance, map_trajectory, stops;
};

bool given(const CLI::App& app, const char* flag) { return app.count(flag) > 0; }

std::uint64_t parse_u64(const std::string& option, const std::string& text) {
  if (text.empty() || !std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; }))
    throw BadValue(option + ": expected a non-negative integer, got '" + text + "'");
  errno = 0;
  char* end = nullptr;
  const unsigned long long v = std::strtoull(text.c_str(), &end, 10);
  if (errno == ERANGE || *end != '\0') throw BadValue(option + ": '" + text + "' is out of range (64-bit)");
  return static_cast<std::uint64_t>(v);
}

double parse_duration(const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end == text.c_str() || *end != '\0' || errno == ERANGE)
    throw BadValue("--duration: expected a number of seconds, got '" + text + "'");
  if (!std::isfinite(v) || v < kMinDurationS || v > kMaxDurationS)
    throw BadValue("--duration: must be between 0.1 s (one LiDAR frame) and " +
                   std::to_string(static_cast<int>(kMaxDurationS)) + " s, got '" + text + "'");
  return v;
}

void add_options(CLI::App& app, Given& g) {
  app.add_option("--scenario", g.scenario, "corridor | stairs | room | campus | urban (required)")->type_name("NAME");
  app.add_option("--seed", g.seed, "noise and motion variations, a non-negative integer (required)")
      ->type_name("N");
  app.add_option("--world-seed", g.world_seed, "world layout (default: the --seed value)")->type_name("M");
  app.add_option("--duration", g.duration, "cut the scenario short after S seconds (0.1 to 100000)")
      ->type_name("S");
  app.add_option("--laps", g.laps, "corridor: walk round the loop N times (default 1, at most 100; e.g. a soak test)")
      ->type_name("N");
  app.add_option("--start-at", g.start_at,
                 "start the walk D metres along the scenario's path, at rest (default 0); the world, its frame and "
                 "the ground truth's frame are those of --world-seed, so a map made by one walk serves another")
      ->type_name("D");
  app.add_option("--lidar", g.lidar,
                 "mid360 (default), spinning32 (32 beams, -16..15 deg, 1800 columns) or spinning64 (64 beams, "
                 "-22.5..22.5 deg, 1024 columns, OS1-64-like)")
      ->type_name("MODEL");
  app.add_option("--traffic", g.traffic,
                 "urban: moving cars and pedestrians (on, the default) or the same run without them (off); an error "
                 "for a scenario without traffic")
      ->type_name("on|off");
  app.add_option("--stops", g.stops,
                 "urban: the car stops N times, at the stop line before each of its first N corners, for 4 s each "
                 "(default 0; an error for a scenario that does not drive, or for more stops than corners)")
      ->type_name("N");
  app.add_option("--imu-time-offset", g.imu_time_offset,
                 "stamp every IMU sample S seconds after its true time (an IMU clock ahead of the LiDAR's; "
                 "negative: behind), at most 1 s either way (default 0); scans and ground truth keep the true time")
      ->type_name("S");
  app.add_option("--format", g.format, "mcap (DIR/recording.mcap, default) or seqdir (a sequence directory in DIR)")
      ->type_name("mcap|seqdir");
  app.add_option("--out", g.out,
                 "output directory, created if missing (required); also gets groundtruth.tum (true T_world_imu at "
                 "200 Hz), scenario.yaml (all parameters), point_labels.bin (0 static / 1 moving per point) and "
                 "moving_objects.csv")
      ->type_name("DIR");
  app.add_option("--classify-map", g.classify_map,
                 "instead of simulating: classify the points of MAP (binary PLY or PCD of float x y z, as "
                 "fuse-map-export writes) against this scenario's world as static, ghost (on a moving object's path) "
                 "or other, printed as key: value lines; --out is not needed (exit 4: MAP unreadable)")
      ->type_name("MAP");
  app.add_option("--classify-tolerance", g.classify_tolerance,
                 "with --classify-map: distance in metres within which a point is on a surface (default 0.3)")
      ->type_name("M");
  app.add_option("--map-trajectory", g.map_trajectory,
                 "with --classify-map: the estimate (TUM) whose frame the map is in; the map is moved into the world "
                 "by the rigid alignment of that estimate onto the true trajectory (an estimator's map starts at its "
                 "first pose, not at the world's origin)")
      ->type_name("EST.tum");
}

/// --scenario, --lidar and --format: each a name from its list.
void check_names(const CLI::App& app, const Given& g, SimOptions& o) {
  if (given(app, "--scenario")) {
    const auto& names = scenario_names();
    if (std::find(names.begin(), names.end(), g.scenario) == names.end())
      throw BadValue("--scenario: unknown scenario '" + g.scenario +
                     "' (expected corridor, stairs, room, campus or urban)");
    o.scenario = g.scenario;
  }
  if (given(app, "--lidar")) {
    const auto& models = LidarConfig::names();
    if (std::find(models.begin(), models.end(), g.lidar) == models.end())
      throw BadValue("--lidar: unknown model '" + g.lidar + "' (expected mid360, spinning32 or spinning64)");
    o.lidar = g.lidar;
  }
  if (given(app, "--format")) {
    if (g.format != "mcap" && g.format != "seqdir")
      throw BadValue("--format: unknown format '" + g.format + "' (expected mcap or seqdir)");
    o.format = g.format == "seqdir" ? OutputFormat::kSeqdir : OutputFormat::kMcap;
  }
  if (given(app, "--traffic")) {
    if (g.traffic != "on" && g.traffic != "off")
      throw BadValue("--traffic: expected on or off, got '" + g.traffic + "'");
    o.traffic = g.traffic == "on";
  }
}

/// --seed, --world-seed (defaults to the seed), --duration and --laps: numbers within bounds.
void check_numbers(const CLI::App& app, const Given& g, SimOptions& o) {
  if (given(app, "--seed")) o.seed = parse_u64("--seed", g.seed);
  o.world_seed = given(app, "--world-seed") ? parse_u64("--world-seed", g.world_seed) : o.seed;
  if (given(app, "--duration")) o.duration_s = parse_duration(g.duration);
  if (given(app, "--laps")) {
    const std::uint64_t laps = parse_u64("--laps", g.laps);
    if (laps < 1 || laps > kMaxLaps) throw BadValue("--laps: must be between 1 and " + std::to_string(kMaxLaps));
    o.laps = static_cast<int>(laps);
  }
  if (given(app, "--stops")) {
    const std::uint64_t stops = parse_u64("--stops", g.stops);
    if (stops > kMaxStops) throw BadValue("--stops: must be between 0 and " + std::to_string(kMaxStops));
    o.stops = static_cast<int>(stops);
  }
  if (given(app, "--start-at")) {
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(g.start_at.c_str(), &end);
    if (g.start_at.empty() || end == g.start_at.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(v) || v < 0.0)
      throw BadValue("--start-at: expected a non-negative number of metres, got '" + g.start_at + "'");
    o.start_at_m = v;
  }
  if (given(app, "--imu-time-offset")) {
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(g.imu_time_offset.c_str(), &end);
    if (g.imu_time_offset.empty() || end == g.imu_time_offset.c_str() || *end != '\0' || errno == ERANGE ||
        !std::isfinite(v) || std::abs(v) > kMaxImuTimeOffsetS)
      throw BadValue("--imu-time-offset: expected a number of seconds between -1 and 1, got '" + g.imu_time_offset + "'");
    o.imu_time_offset_s = v;
  }
  if (given(app, "--classify-tolerance")) {
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(g.classify_tolerance.c_str(), &end);
    if (g.classify_tolerance.empty() || end == g.classify_tolerance.c_str() || *end != '\0' || errno == ERANGE ||
        !std::isfinite(v) || !(v > 0.0) || v > kMaxClassifyToleranceM)
      throw BadValue("--classify-tolerance: expected a distance above 0 and at most 10 m, got '" +
                     g.classify_tolerance + "'");
    o.classify_tolerance_m = v;
  }
}

/// The required options (checked here rather than by CLI11 to keep the messages), --laps's
/// restriction to the corridor, --traffic's to a scenario with traffic and the classifier's mode
/// (no --out needed; --classify-tolerance only with it).
void check_complete(const CLI::App& app, const Given& g, SimOptions& o) {
  if (given(app, "--out") && g.out.empty()) throw BadValue("--out: empty directory name");
  o.out_dir = g.out;
  if (given(app, "--classify-map") && g.classify_map.empty()) throw BadValue("--classify-map: empty file name");
  o.classify_map = g.classify_map;
  if (!given(app, "--scenario")) throw BadValue("missing --scenario");
  if (!given(app, "--seed")) throw BadValue("missing --seed");
  if (!given(app, "--out") && o.classify_map.empty()) throw BadValue("missing --out");
  if (o.laps > 1 && o.scenario != "corridor") throw BadValue("--laps: only the corridor's path is a loop");
  if (given(app, "--stops") && o.stops > 0 && !scenario_can_stop(o.scenario))
    throw BadValue("--stops: the scenario '" + o.scenario + "' does not stop at crossings (only urban does)");
  if (given(app, "--traffic") && !scenario_has_traffic(o.scenario))
    throw BadValue("--traffic: the scenario '" + o.scenario + "' has no moving objects (only urban has)");
  if (given(app, "--classify-tolerance") && o.classify_map.empty())
    throw BadValue("--classify-tolerance: only with --classify-map");
  if (given(app, "--map-trajectory") && (o.classify_map.empty() || g.map_trajectory.empty()))
    throw BadValue("--map-trajectory: a file name, only with --classify-map");
  o.map_trajectory = g.map_trajectory;
}

}  // namespace

std::optional<int> parse_arguments(int argc, char** argv, SimOptions& options) {
  const auto app = cli::make_app(
      "fuse-sim",
      "Simulates a LiDAR + IMU sequence with exact ground truth. Identical arguments give byte-identical files.",
      "Exit codes: 0 success, 1 simulation failure, 2 bad command line, 4 --classify-map file unreadable.");
  Given g;
  add_options(*app, g);
  if (const std::optional<int> code = cli::parse(*app, argc, argv)) return code;
  SimOptions o;
  try {
    check_names(*app, g, o);
    check_numbers(*app, g, o);
    check_complete(*app, g, o);
  } catch (const BadValue& e) {
    return cli::usage_error(*app, e.what());
  }
  options = o;
  return std::nullopt;
}

}  // namespace fuse::sim

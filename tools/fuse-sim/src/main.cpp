// fuse-sim: LiDAR + IMU simulator with exact ground truth.
//
//   fuse-sim --scenario corridor|stairs|room|campus|urban --seed N [--world-seed M] [--duration S]
//            [--laps N] [--start-at D] [--stops N] [--lidar mid360|spinning32|spinning64] [--traffic on|off]
//            [--imu-time-offset S] [--format mcap|seqdir] --out DIR
//   fuse-sim --scenario ... --seed N [the run's other scenario options] --classify-map MAP.ply|MAP.pcd
//            [--classify-tolerance M]
//
// Writes DIR/recording.mcap (or, with --format seqdir, a sequence directory in DIR),
// DIR/groundtruth.tum (true T_world_imu at 200 Hz, TUM, 9 decimals), DIR/scenario.yaml (every
// parameter used), DIR/point_labels.bin (static / moving label of every point) and
// DIR/moving_objects.csv (the movers). --world-seed fixes the world (default N), --seed the noise
// and motion variations; identical arguments give byte-identical files. --duration S cuts the
// scenario short; --start-at D starts the walk D metres along the path (the same world and frame: a
// map made by one walk serves another). --traffic off: urban without its moving objects, all else
// equal. --stops N: urban stops at the stop line before its first N corners, 4 s each.
// --classify-map rebuilds the same world and prints how many map points are static, ghost (on a
// moving object's path) or other.
// Exit codes: 0 success (and after --help / --version), 1 simulation failure, 2 bad command line
// (the command-line convention of every binary: fuse/cli/cli.hpp), 4 --classify-map file unreadable.
#include <exception>
#include <iostream>
#include <optional>

#include "fuse/core/logging.hpp"
#include "fuse/sim/cli.hpp"
#include "fuse/sim/cloud_reader.hpp"
#include "fuse/sim/map_classifier.hpp"
#include "fuse/sim/simulator.hpp"

namespace {

constexpr int kExitFailure = 1;
constexpr int kExitUnreadableInput = 4;

int classify(const fuse::sim::SimOptions& options) {
  try {
    const fuse::sim::MapClassification c = fuse::sim::classify_map_file(options);
    std::cout << "map_points: " << c.map_points << "\nstatic_points: " << c.static_points
              << "\nghost_points: " << c.ghost_points << "\nother_points: " << c.other_points
              << "\ntolerance_m: " << options.classify_tolerance_m << "\n";
  } catch (const fuse::sim::CloudReadError& e) {
    fuse::logger("sim")->error("--classify-map: {}", e.what());
    return kExitUnreadableInput;
  } catch (const std::exception& e) {
    fuse::logger("sim")->error("{}", e.what());
    return kExitFailure;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  fuse::sim::SimOptions options;
  if (const std::optional<int> code = fuse::sim::parse_arguments(argc, argv, options)) return *code;
  if (!options.classify_map.empty()) return classify(options);
  try {
    const fuse::sim::SimSummary s = fuse::sim::run_simulation(options);
    std::cout << "scans " << s.scans << ", imu samples " << s.imu_samples << ", points " << s.points
              << ", duration " << s.duration_s << " s, travelled " << s.travelled_m << " m of the scenario's "
              << s.path_length_m << " m path, wall time " << s.wall_time_s << " s\n";
  } catch (const std::exception& e) {
    fuse::logger("sim")->error("{}", e.what());
    return kExitFailure;
  }
  return 0;
}

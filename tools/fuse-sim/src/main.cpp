// fuse-sim: LiDAR + IMU simulator with exact ground truth.
//
//   fuse-sim --scenario corridor|stairs|room|campus --seed N [--world-seed M] [--duration S]
//            [--laps N] [--start-at D] [--lidar mid360|spinning32] [--format mcap|seqdir] --out DIR
//
// Writes DIR/recording.mcap (or, with --format seqdir, a sequence directory in DIR),
// DIR/groundtruth.tum (true T_world_imu at 200 Hz, TUM, 9 decimals) and DIR/scenario.yaml (every
// parameter used). --world-seed fixes the world (default N), --seed the noise and motion
// variations; identical arguments give byte-identical files. --duration S cuts the scenario short;
// --start-at D starts the walk D metres along the path (the same world and frame: a map made by
// one walk serves another).
// Exit codes: 0 success (and after --help / --version), 1 simulation failure, 2 bad command line
// (the command-line convention of every binary: fuse/cli/cli.hpp).
#include <exception>
#include <iostream>
#include <optional>

#include "fuse/core/logging.hpp"
#include "fuse/sim/cli.hpp"
#include "fuse/sim/simulator.hpp"

int main(int argc, char** argv) {
  fuse::sim::SimOptions options;
  if (const std::optional<int> code = fuse::sim::parse_arguments(argc, argv, options)) return *code;
  try {
    const fuse::sim::SimSummary s = fuse::sim::run_simulation(options);
    std::cout << "scans " << s.scans << ", imu samples " << s.imu_samples << ", points " << s.points
              << ", duration " << s.duration_s << " s, travelled " << s.travelled_m << " m of the scenario's "
              << s.path_length_m << " m path, wall time " << s.wall_time_s << " s\n";
  } catch (const std::exception& e) {
    fuse::logger("sim")->error("{}", e.what());
    return 1;
  }
  return 0;
}

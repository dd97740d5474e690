// fuse-run: single-process offline runner.
//
//   fuse-run --config FILE --input INPUT --out DIR [--set key=value]... [--log-level LEVEL]
//            [--load-map SNAPSHOT [--initial-pose X Y Z YAW_DEG [--pose-std-xy M] [--pose-std-yaw DEG]]]
//            [--save-map SNAPSHOT] [--extrinsic-from input|config]  (--help lists them; --version)
//
// With --load-map the run finds its start in the map by itself (estimator.global_localization;
// around --initial-pose when given), and writes its poses in the map's frame once found.
//
// INPUT is an MCAP recording (file) or a sequence directory (folder). A calib.yaml in a sequence
// directory (or the calibration record of a recording) overrides the config's extrinsic.
// Writes DIR/trajectory.tum (IMU pose at scan ends), DIR/trajectory_imu.tum (IMU rate),
// DIR/timing.csv and DIR/diagnostics.csv, and prints per-scan time mean / P95 / max, the
// tracking status at the end and the stretches spent relocalizing or lost.
// Exit codes: 0 finished, 1 input error or an output directory that cannot be created,
// 2 bad arguments or config (an empty config file too), 3 the run diverged: the estimator gave up
// (DivergenceError) or was lost at the end of the run or for longer than
// estimator.tracking.max_lost_s (the reason is printed).
#include <cmath>
#include <iomanip>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "fuse/cli/cli.hpp"
#include "fuse/core/logging.hpp"
#include "runner.hpp"

namespace {
constexpr int kExitInput = 1, kExitUsage = 2, kExitDiverged = 3;
}  // namespace

int main(int argc, char** argv) {
  std::string config_file, input, out_dir, level = "info", load_map, save_map;
  std::vector<std::string> overrides;
  std::vector<double> initial_pose;
  double pose_std_xy = 1.0, pose_std_yaw_deg = 10.0;
  const auto app = fuse::cli::make_app(
      "fuse-run",
      "Single-process offline runner: the estimator on an MCAP recording or a sequence directory (its "
      "calibration overrides the config's extrinsic). Writes DIR/trajectory.tum (IMU pose at scan ends), "
      "trajectory_imu.tum, timing.csv and diagnostics.csv; prints per-scan time mean / P95 / max and the "
      "tracking status.",
      "Exit codes: 0 finished, 1 input error or an output directory that cannot be created, 2 bad arguments or "
      "config, 3 the run diverged (the estimator gave up, or was lost at the end or for longer than "
      "estimator.tracking.max_lost_s).");
  app->add_option("--config", config_file, "the system config (YAML)")->type_name("FILE")->required();
  app->add_option("--input", input, "MCAP recording or sequence directory")->type_name("INPUT")->required();
  app->add_option("--out", out_dir, "output directory")->type_name("DIR")->required();
  app->add_option("--set", overrides, "override a config value (repeatable), e.g. --set estimator.preprocess.deskew=false")
      ->type_name("KEY=VALUE")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  app->add_option("--log-level", level, "trace|debug|info|warn|error (default info)")->type_name("L");
  app->add_option("--load-map", load_map, "start from this map snapshot")->type_name("SNAPSHOT");
  app->add_option("--save-map", save_map, "write the map to this snapshot at the end")->type_name("SNAPSHOT");
  std::string extrinsic_from = "input";
  app->add_option("--extrinsic-from", extrinsic_from,
                  "input (default): a recording's calibration or a sequence's calib.yaml overrides the config's extrinsic; "
                  "config: the config's extrinsic is used always")
      ->type_name("input|config")
      ->check(CLI::IsMember({"input", "config"}));
  auto* pose_opt = app->add_option("--initial-pose", initial_pose,
                                   "with --load-map: the IMU's pose in the map at the start (metres, heading in degrees "
                                   "about z; roll and pitch come from gravity); it is checked against the map, and refused "
                                   "when nothing near it fits")
                       ->type_name("X Y Z YAW_DEG")
                       ->expected(4);
  app->add_option("--pose-std-xy", pose_std_xy, "σ of the initial pose's horizontal position in m (default 1)")
      ->type_name("M")
      ->needs(pose_opt);
  app->add_option("--pose-std-yaw", pose_std_yaw_deg, "σ of the initial pose's heading in degrees (default 10)")
      ->type_name("DEG")
      ->needs(pose_opt);
  if (const std::optional<int> code = fuse::cli::parse(*app, argc, argv)) return *code;
  try {
    fuse::set_log_level(level);
  } catch (const std::exception& e) {
    std::cerr << "fuse-run: --log-level: " << e.what() << "\n";
    return kExitUsage;
  }
  fuse::RunnerConfig config;
  try {
    config = fuse::load_runner_config(config_file, overrides);
  } catch (const std::exception& e) {
    std::cerr << "fuse-run: config error: " << e.what() << "\n";
    return kExitUsage;
  }
  config.load_map = load_map;
  config.save_map = save_map;
  config.extrinsic_from = extrinsic_from;
  if (!initial_pose.empty()) {
    if (initial_pose.size() != 4) return fuse::cli::usage_error(*app, "--initial-pose: expected four numbers: X Y Z YAW_DEG");
    if (load_map.empty()) return fuse::cli::usage_error(*app, "--initial-pose: needs --load-map (a pose in which map?)");
    for (double v : initial_pose) {
      if (!std::isfinite(v)) return fuse::cli::usage_error(*app, "--initial-pose: every value must be a finite number");
    }
    if (!(pose_std_xy > 0.0 && pose_std_xy <= 100.0)) return fuse::cli::usage_error(*app, "--pose-std-xy: must be in (0, 100] m");
    if (!(pose_std_yaw_deg > 0.0 && pose_std_yaw_deg <= 180.0)) {
      return fuse::cli::usage_error(*app, "--pose-std-yaw: must be in (0, 180] degrees");
    }
    fuse::InitialPose p;
    p.position = Eigen::Vector3d(initial_pose[0], initial_pose[1], initial_pose[2]);
    p.yaw = initial_pose[3] * M_PI / 180.0;
    p.std_xy = pose_std_xy;
    p.std_yaw = pose_std_yaw_deg * M_PI / 180.0;
    config.initial_pose = p;
  }
  if (const std::string why = fuse::prepare_output_dir(out_dir); !why.empty()) {
    std::cerr << "fuse-run: --out: " << why << "\n";
    return kExitInput;
  }
  const fuse::RunSummary s = fuse::run_offline(config, input, out_dir);
  std::cout << "scans: " << s.scans << "\nscans_updated: " << s.scans_updated << "\nimu_samples: " << s.imu_samples
            << "\nscan_time_mean_ms: " << s.mean_ms << "\nscan_time_p95_ms: " << s.p95_ms
            << "\nscan_time_max_ms: " << s.max_ms << "\nscan_cpu_median_ms: " << s.cpu_median_ms
            << "\nscan_cpu_p99_ms: " << s.cpu_p99_ms << "\nscan_cpu_max_ms: " << s.cpu_max_ms << "\n";
  std::cout << "time_offset_s: " << s.time_offset << "\n";
  std::cout << "moving_points_screened: " << s.moving_screened << "\nmap_points_carved: " << s.map_carved << "\n";
  for (const auto& [reason, n] : s.input_rejected) std::cout << "input_rejected_" << reason << ": " << n << "\n";
  for (const auto& [reason, n] : s.estimator_counts) std::cout << "estimator_" << reason << ": " << n << "\n";
  if (s.initialised) {
    std::cout << "tracking: " << fuse::to_string(s.tracking) << (s.tracking_reason.empty() ? "" : " (" + s.tracking_reason + ")")
              << "\ntracking_relocalizing_s: " << s.relocalizing_s << "\ntracking_lost_s: " << s.lost_s << "\n";
    for (const auto& e : s.episodes) {
      std::cout << "tracking_episode: " << fuse::to_string(e.status) << " from t=" << std::fixed << std::setprecision(3)
                << e.t_begin << " for " << std::setprecision(2) << e.duration << " s: " << e.reason << "\n"
                << std::defaultfloat;
    }
  }
  if (s.searched_map) {
    std::cout << "localization: " << (s.localized ? "localized" : "not localized") << " (" << s.localization << ")\n"
              << "localization_searches: " << s.searches << "\nlocalization_search_s: " << s.search_s << "\n";
    if (s.localized) {
      std::cout << "localization_t: " << std::fixed << std::setprecision(3) << s.localized_t << std::defaultfloat
                << "\nlocalization_after_s: " << s.localized_after_s << "\n";
    }
    if (s.initial_pose_refused) std::cout << "warning: the initial pose was refused: nothing near it fits the map\n";
  }
  if (!s.error.empty()) {
    fuse::logger("run")->error("{}", s.error);
    std::cout << "error: " << s.error << "\n";
    return s.diverged ? kExitDiverged : kExitInput;
  }
  if (const auto a = s.estimator_counts.find("recovery_ambiguous"); a != s.estimator_counts.end() && a->second > 0) {
    // Not a divergence by itself (docs/chaos.md, "Ambiguous re-localisations"), but never silent.
    fuse::logger("run")->warn("{} ambiguous re-localisation(s): the heading was turned although a result at another "
                              "heading fitted nearly as well; the track may be mirrored (the log names each)",
                              a->second);
    std::cout << "warning: " << a->second << " ambiguous re-localisation(s), the track may be mirrored\n";
  }
  if (s.diverged) {
    fuse::logger("run")->error("the run diverged: {}", s.divergence);
    std::cout << "diverged: " << s.divergence << "\n";
  }
  std::cout << "output: " << out_dir << "\n";
  return s.diverged ? kExitDiverged : 0;
}

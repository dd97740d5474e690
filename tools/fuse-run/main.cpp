// fuse-run: single-process offline runner.
//
//   fuse-run --config FILE --input INPUT --out DIR [--set key=value]... [--log-level LEVEL]
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
#include <iomanip>
#include <iostream>
#include <string>
#include <vector>

#include "fuse/core/logging.hpp"
#include "runner.hpp"

namespace {
constexpr int kExitInput = 1, kExitUsage = 2, kExitDiverged = 3;

void usage(std::ostream& os) {
  os << "usage: fuse-run --config FILE --input INPUT --out DIR [--set key=value]... [--log-level LEVEL]\n"
        "                [--load-map SNAPSHOT] [--save-map SNAPSHOT]\n"
        "  INPUT: MCAP recording or sequence directory\n"
        "  --set: override a config value, e.g. --set estimator.preprocess.deskew=false\n";
}
}  // namespace

int main(int argc, char** argv) {
  std::string config_file, input, out_dir, level = "info", load_map, save_map;
  std::vector<std::string> overrides;
  std::vector<std::string> args(argv + 1, argv + argc);
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&](const char* name) -> const std::string* {
      if (i + 1 >= args.size()) {
        std::cerr << "fuse-run: " << name << " needs a value\n";
        return nullptr;
      }
      return &args[++i];
    };
    const std::string* v = nullptr;
    if (a == "--help" || a == "-h") {
      usage(std::cout);
      return 0;
    } else if (a == "--config" && (v = value("--config"))) {
      config_file = *v;
    } else if (a == "--input" && (v = value("--input"))) {
      input = *v;
    } else if (a == "--out" && (v = value("--out"))) {
      out_dir = *v;
    } else if (a == "--set" && (v = value("--set"))) {
      overrides.push_back(*v);
    } else if (a == "--log-level" && (v = value("--log-level"))) {
      level = *v;
    } else if (a == "--load-map" && (v = value("--load-map"))) {
      load_map = *v;
    } else if (a == "--save-map" && (v = value("--save-map"))) {
      save_map = *v;
    } else {
      if (v == nullptr && (a == "--config" || a == "--input" || a == "--out" || a == "--set" || a == "--log-level" ||
                           a == "--load-map" || a == "--save-map")) {
        return kExitUsage;
      }
      std::cerr << "fuse-run: unknown argument '" << a << "'\n";
      usage(std::cerr);
      return kExitUsage;
    }
  }
  if (config_file.empty() || input.empty() || out_dir.empty()) {
    std::cerr << "fuse-run: --config, --input and --out are required\n";
    usage(std::cerr);
    return kExitUsage;
  }
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
  if (const std::string why = fuse::prepare_output_dir(out_dir); !why.empty()) {
    std::cerr << "fuse-run: --out: " << why << "\n";
    return kExitInput;
  }
  const fuse::RunSummary s = fuse::run_offline(config, input, out_dir);
  std::cout << "scans: " << s.scans << "\nscans_updated: " << s.scans_updated << "\nimu_samples: " << s.imu_samples
            << "\nscan_time_mean_ms: " << s.mean_ms << "\nscan_time_p95_ms: " << s.p95_ms
            << "\nscan_time_max_ms: " << s.max_ms << "\n";
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
  if (!s.error.empty()) {
    fuse::logger("run")->error("{}", s.error);
    std::cout << "error: " << s.error << "\n";
    return s.diverged ? kExitDiverged : kExitInput;
  }
  if (s.diverged) {
    fuse::logger("run")->error("the run diverged: {}", s.divergence);
    std::cout << "diverged: " << s.divergence << "\n";
  }
  std::cout << "output: " << out_dir << "\n";
  return s.diverged ? kExitDiverged : 0;
}

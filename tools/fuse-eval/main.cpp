// fuse-eval: evaluates an estimated trajectory against ground truth with evo's ATE / RPE
// definitions plus terminal drift (docs/evaluation-metrics.md). Prints "name: value" lines or
// one JSON object on stdout; any bad input gives a message on stderr and exit code 2. With
// --frame-of GT EST the estimate is put into the reference frame by another run's alignment (a
// run localized on a saved map, in the frame of the walk that made the map) and not aligned itself.
// With --plot DIR it also draws the evaluation's figures with gnuplot (fuse/eval/plot.hpp).
#include <exception>
#include <filesystem>
#include <optional>
#include <iostream>
#include <string>

#include "arguments.hpp"
#include "fuse/eval/alignment.hpp"
#include "fuse/eval/evaluate.hpp"
#include "fuse/eval/plot.hpp"
#include "fuse/eval/scan_times.hpp"
#include "fuse/eval/trajectory.hpp"

namespace {

constexpr int kExitOk = 0;
constexpr int kExitPlotFailed = 1;
constexpr int kExitBadInput = 2;

/// Draws the figures; a failure here is not a bad input (the evaluation was printed).
int plot(const fuse::eval_tool::Arguments& args, const fuse::eval::ErrorSeries& series,
         const std::optional<fuse::eval::ScanTimes>& times) {
  fuse::eval::PlotConfig config;
  config.title = std::filesystem::path(args.est_path).filename().string();
  config.rpe_delta_m = args.config.rpe_delta_m;
  try {
    for (const std::string& figure : fuse::eval::write_plots(args.plot_dir, series, times ? &*times : nullptr, config)) {
      std::cerr << "fuse-eval: wrote " << figure << "\n";
    }
  } catch (const std::exception& e) {
    std::cerr << "fuse-eval: --plot: " << e.what() << "\n";
    return kExitPlotFailed;
  }
  return kExitOk;
}

int run(const fuse::eval_tool::Arguments& args) {
  const fuse::eval::Trajectory gt = fuse::eval::read_trajectory(args.gt_path, args.format);
  fuse::eval::Trajectory est = fuse::eval::read_trajectory(args.est_path, args.format);
  if (!args.frame_of.empty()) {
    // The other run's estimate -> reference transform, applied to this estimate as it is.
    fuse::eval::EvaluationConfig other = args.config;
    other.alignment = fuse::eval::AlignmentMode::kSE3;
    const fuse::eval::EvaluationResult frame =
        fuse::eval::evaluate(fuse::eval::read_trajectory(args.frame_of[0], args.format),
                             fuse::eval::read_trajectory(args.frame_of[1], args.format), other);
    est = fuse::eval::transform(est, frame.alignment);
  }
  // Read before anything is printed: a bad timing file is a bad input like a bad trajectory.
  std::optional<fuse::eval::ScanTimes> times;
  if (!args.timing_path.empty()) times = fuse::eval::read_scan_times(args.timing_path);
  fuse::eval::ErrorSeries series;
  const fuse::eval::EvaluationResult result =
      fuse::eval::evaluate(gt, est, args.config, args.plot_dir.empty() ? nullptr : &series);
  std::cout << (args.json ? fuse::eval::format_json(result) : fuse::eval::format_text(result)) << std::flush;
  return args.plot_dir.empty() ? kExitOk : plot(args, series, times);
}

}  // namespace

int main(int argc, char** argv) {
  fuse::eval_tool::Arguments args;
  if (const std::optional<int> code = fuse::eval_tool::parse_arguments(argc, argv, args)) return *code;
  try {
    return run(args);
  } catch (const std::exception& e) {
    std::cerr << "fuse-eval: " << e.what() << "\n";
  } catch (...) {
    std::cerr << "fuse-eval: unknown error\n";
  }
  return kExitBadInput;
}

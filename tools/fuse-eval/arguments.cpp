// Command-line parsing of fuse-eval: every value is checked before anything is read.
#include "arguments.hpp"

#include <cmath>
#include <stdexcept>

#include "fuse/cli/cli.hpp"

namespace fuse::eval_tool {

std::optional<int> parse_arguments(int argc, char** argv, Arguments& a) {
  const auto app = cli::make_app(
      "fuse-eval",
      "Evaluates an estimated trajectory against a reference with evo's ATE and RPE definitions plus terminal "
      "drift (docs/evaluation-metrics.md). Prints 'name: value' lines, or one JSON object.",
      "Exit codes: 0 success, 1 the plots could not be drawn (gnuplot missing or failing), 2 bad arguments, "
      "unreadable files or no evaluation possible.");
  std::string format = "tum", align = "se3";
  double delta = a.config.rpe_delta_m, t_max_diff = a.config.max_time_difference;
  app->add_option("--gt", a.gt_path, "reference (ground truth) trajectory")->type_name("FILE")->required();
  app->add_option("--est", a.est_path, "estimated trajectory")->type_name("FILE")->required();
  app->add_option("--format", format, "tum (default; matched by timestamp) or kitti (matched by index)")
      ->type_name("tum|kitti");
  app->add_option("--delta", delta, "RPE delta in metres of reference path (default 1.0)")->type_name("M");
  app->add_option("--t-max-diff", t_max_diff, "largest timestamp difference of a match in s (default 0.01)")
      ->type_name("S");
  app->add_option("--align", align, "ATE alignment: se3 (default, evo_ape -a), sim3 (-a -s), none")
      ->type_name("se3|sim3|none");
  app->add_flag("--json", a.json, "print one JSON object instead of 'name: value' lines");
  app->add_option("--frame-of", a.frame_of,
                  "bring the estimate into the reference frame with the SE(3) alignment of another run (its reference "
                  "and estimate, e.g. the walk that made the map this run was localized on) instead of aligning it "
                  "itself: the error of a localized run, unaligned")
      ->type_name("GT EST")
      ->expected(2);
  app->add_option("--plot", a.plot_dir,
                  "also draw SVG figures into DIR with gnuplot: top and side view of the estimate against the "
                  "reference, APE and RPE (translation in m, rotation in degrees) over the distance travelled, and "
                  "with --timing the per-scan time; the data behind each figure is written beside it")
      ->type_name("DIR");
  app->add_option("--timing", a.timing_path, "fuse-run's timing.csv, drawn as per-scan time over the run (needs --plot)")
      ->type_name("FILE");
  if (const std::optional<int> code = cli::parse(*app, argc, argv)) return code;
  try {
    a.format = eval::parse_trajectory_format(format);
  } catch (const std::invalid_argument& e) {
    return cli::usage_error(*app, std::string("--format: ") + e.what());
  }
  try {
    a.config.alignment = eval::parse_alignment_mode(align);
  } catch (const std::invalid_argument& e) {
    return cli::usage_error(*app, std::string("--align: ") + e.what());
  }
  if (!std::isfinite(delta)) return cli::usage_error(*app, "--delta: not a finite number");
  if (!std::isfinite(t_max_diff)) return cli::usage_error(*app, "--t-max-diff: not a finite number");
  if (!a.frame_of.empty()) {
    if (a.frame_of.size() != 2) return cli::usage_error(*app, "--frame-of: expected two files: GT EST");
    if (app->count("--align") > 0 && align != "none") {
      return cli::usage_error(*app, "--frame-of: the estimate is not aligned itself (--align none or nothing)");
    }
    a.config.alignment = eval::AlignmentMode::kNone;
  }
  if (!a.timing_path.empty() && a.plot_dir.empty()) return cli::usage_error(*app, "--timing: needs --plot DIR");
  if (app->count("--plot") > 0 && a.plot_dir.empty()) return cli::usage_error(*app, "--plot: empty directory name");
  a.config.rpe_delta_m = delta;
  a.config.max_time_difference = t_max_diff;
  a.config.association =
      a.format == eval::TrajectoryFormat::kKitti ? eval::AssociationMode::kIndex : eval::AssociationMode::kTimestamp;
  try {
    a.config.validate();
  } catch (const std::invalid_argument& e) {
    return cli::usage_error(*app, e.what());
  }
  return std::nullopt;
}

}  // namespace fuse::eval_tool

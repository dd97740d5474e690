// Command line of fuse-eval (CLI11, the convention of every binary: fuse/cli/cli.hpp).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "fuse/eval/evaluate.hpp"
#include "fuse/eval/trajectory.hpp"

namespace fuse::eval_tool {

struct Arguments {
  std::string gt_path;
  std::string est_path;
  eval::TrajectoryFormat format = eval::TrajectoryFormat::kTum;
  eval::EvaluationConfig config;  ///< association follows the format: KITTI matches by index
  bool json = false;
  /// --frame-of GT EST: the estimate is first moved by the SE(3) alignment of another run (EST
  /// against GT), e.g. the walk that made the map it was localized on; then no alignment of its own.
  std::vector<std::string> frame_of;
  std::string plot_dir;     ///< --plot DIR: figures of the evaluation (empty: none)
  std::string timing_path;  ///< --timing FILE: fuse-run's timing.csv, drawn with --plot
};

/// Parses and checks argv into `a`. std::nullopt: go on; otherwise the exit code to end with
/// (0 after --help / --version, 2 after a usage error, printed naming the flag).
std::optional<int> parse_arguments(int argc, char** argv, Arguments& a);

}  // namespace fuse::eval_tool

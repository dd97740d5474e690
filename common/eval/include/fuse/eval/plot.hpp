// Figures of an evaluation (fuse-eval --plot): the data behind each figure is written as a
// whitespace-separated .dat file with a header comment, a gnuplot script draws SVG figures from
// them, and gnuplot is run on it.
#pragma once

#include <string>
#include <vector>

#include "fuse/eval/evaluate.hpp"
#include "fuse/eval/scan_times.hpp"

namespace fuse::eval {

struct PlotConfig {
  std::string gnuplot = "gnuplot";  ///< program run on the script (found on PATH)
  std::string title;                ///< named in every figure's title (e.g. the estimate's file)
  double rpe_delta_m = kDefaultRpeDeltaM;  ///< the pair spacing the RPE series was made with
};

/// Writes into `dir` (created if missing):
///   trajectory.dat  t, distance, reference x y z, aligned estimate x y z per matched pose
///   ape.dat         distance, t, APE translation (m), APE rotation (deg) per matched pose
///   rpe.dat         distance and t at each pair's end, RPE translation (m) and rotation (deg)
///   scan_time.dat   time since the first scan (s), per-scan time (ms)   (only with `times`)
///   plots.gp        the gnuplot script
/// and runs gnuplot on the script, which draws trajectory_top.svg (x-y), trajectory_side.svg
/// (x-z), ape.svg, rpe.svg (each translation and rotation error over the distance travelled) and
/// scan_time.svg (only with `times`). Returns the figures' paths. Throws std::runtime_error when
/// a file cannot be written, gnuplot cannot be started or ends with an error, or a figure is missing.
std::vector<std::string> write_plots(const std::string& dir, const ErrorSeries& series, const ScanTimes* times,
                                     const PlotConfig& config = {});

}  // namespace fuse::eval

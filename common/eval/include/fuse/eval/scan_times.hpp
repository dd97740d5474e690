// Per-scan processing times of a run: fuse-run's timing.csv, and the mean / P95 / max the paper
// reports.
#pragma once

#include <string>
#include <vector>

namespace fuse::eval {

/// The time each scan took, in scan order.
struct ScanTimes {
  std::vector<double> t;         ///< scan time (s)
  std::vector<double> total_ms;  ///< estimator time spent on the scan (ms)
};

/// Reads fuse-run's timing.csv (header "scan,t,...,total_ms"; the columns are found by name).
/// Throws std::runtime_error naming the file and line of a missing column, a row of the wrong
/// width, a value that is not a finite number, a negative time or scan times that decrease.
ScanTimes read_scan_times(const std::string& path);

/// Mean, median, 95th and 99th percentile (the value at rank floor(q n) of the sorted times) and
/// maximum: the paper's mean / P95 / max, and the tail against the median (issue 19's stall goal).
struct TimeStatistics {
  double mean_ms = 0.0;
  double median_ms = 0.0;
  double p95_ms = 0.0;
  double p99_ms = 0.0;
  double max_ms = 0.0;
};
/// All zero for no times.
TimeStatistics time_statistics(const std::vector<double>& ms);

}  // namespace fuse::eval

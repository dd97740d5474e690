// The zero-velocity update at rest (estimator.zero_velocity, docs/architecture.md "At rest") on a
// drive that stops: 45 s of the urban drive (a Mid-360 on the roof, with traffic) that waits 4 s at
// the stop line before its first corner (fuse-sim --stops 1). The update must fire where the car
// rests, at the start and at the stop line, and nowhere while it moves (judged by the simulator's
// truth), and must cost no accuracy.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "fuse/eval/evaluate.hpp"
#include "fuse/eval/trajectory.hpp"
#include "runner.hpp"

namespace fuse {
namespace {

namespace fs = std::filesystem;

const std::string kData = std::string(FUSE_TEST_DATA) + "/urban45_stop1";
const std::string kConfig = std::string(FUSE_CONFIG_DIR) + "/mid360.yaml";
constexpr double kScanS = 0.1;
/// m/s: a scan flagged at rest may end while the car still creeps this fast (the simulator's stops
/// are smooth: flagged scans have ended at 0.033 m/s at most).
constexpr double kCreep = 0.05;

/// The simulator's speed at t (finite difference of its 200 Hz truth).
double true_speed(const std::vector<StampedPose>& gt, double t) {
  const auto it = std::lower_bound(gt.begin(), gt.end(), t, [](const StampedPose& p, double x) { return p.t < x; });
  if (it == gt.begin() || it == gt.end()) return 0.0;
  const StampedPose& b = *it;
  const StampedPose& a = *(it - 1);
  return (b.p - a.p).norm() / (b.t - a.t);
}

/// Whether the car rested throughout [t0, t1] by the truth.
bool rested(const std::vector<StampedPose>& gt, double t0, double t1) {
  for (const StampedPose& p : gt) {
    if (p.t >= t0 && p.t <= t1 && true_speed(gt, p.t) > 1e-4) return false;
  }
  return true;
}

struct Flag {
  double t = 0.0;
  bool at_rest = false;
};

/// The `t` and `at_rest` columns of fuse-run's diagnostics.csv.
std::vector<Flag> read_flags(const fs::path& csv) {
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  std::stringstream hs(line);
  for (std::string cell; std::getline(hs, cell, ',');) header.push_back(cell);
  const auto column = [&](const std::string& name) {
    return static_cast<std::size_t>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  const std::size_t t_col = column("t"), rest_col = column("at_rest");
  EXPECT_LT(rest_col, header.size()) << "diagnostics.csv has no at_rest column";
  std::vector<Flag> flags;
  while (std::getline(in, line)) {
    std::vector<std::string> cells;
    std::stringstream ls(line);
    for (std::string cell; std::getline(ls, cell, ',');) cells.push_back(cell);
    if (cells.size() != header.size()) continue;
    flags.push_back({std::stod(cells[t_col]), cells[rest_col] == "1"});
  }
  return flags;
}

class Stops : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kData + "/recording.mcap")) GTEST_SKIP() << "no simulated drive with a stop (the fuse_sim_data fixture)";
    gt_ = eval::read_tum(kData + "/groundtruth.tum");
    ASSERT_FALSE(gt_.empty());
  }
  RunSummary run(bool zero_velocity, const std::string& out) {
    return run_offline(load_runner_config(kConfig, {std::string("estimator.zero_velocity.enabled=") +
                                                    (zero_velocity ? "true" : "false")}),
                       kData + "/recording.mcap", out);
  }
  double ate(const RunSummary& s) const { return eval::evaluate(gt_, s.trajectory, eval::EvaluationConfig{}).ate.rmse; }
  std::vector<StampedPose> gt_;
};

TEST_F(Stops, FireWhereTheCarRestsAndNowhereElse) {
  const fs::path out = fs::temp_directory_path() / ("fuse-zero-velocity-" + std::to_string(::getpid()));
  const RunSummary s = run(true, out.string());
  ASSERT_TRUE(s.error.empty()) << s.error;
  ASSERT_FALSE(s.diverged) << s.divergence;
  const std::vector<Flag> flags = read_flags(out / "diagnostics.csv");
  fs::remove_all(out);
  ASSERT_GT(flags.size(), 400u);

  const double t_start = gt_.front().t + 5.0;  // after the rest at the start and the pull away
  std::size_t flagged = 0, moving = 0, stop_rested = 0, stop_found = 0;
  double fastest = 0.0;
  for (const Flag& f : flags) {
    const double v = true_speed(gt_, f.t);
    if (f.at_rest) {
      ++flagged;
      fastest = std::max(fastest, v);
      if (v > kCreep) ++moving;
    }
    if (f.t > t_start && rested(gt_, f.t - kScanS, f.t)) {
      ++stop_rested;
      if (f.at_rest) ++stop_found;
    }
  }
  std::cout << flagged << " scans flagged at rest (the fastest while the car still moved at " << fastest
            << " m/s); of the " << stop_rested << " scans wholly in the stop " << stop_found << " found; counter "
            << s.estimator_counts.at("zero_velocity_updates") << "\n";
  // Measured: 43 scans wholly in the stop, 41 found (the two missed at its ends, where the body
  // still settles on its suspension); flagged scans end at 0.033 m/s at most (the simulator's smooth
  // stop creeps in); 82 flagged in all, with the rest at the start.
  EXPECT_EQ(moving, 0u) << "flagged while the car moved faster than " << kCreep << " m/s";
  EXPECT_GE(stop_rested, 38u) << "the drive must stop for 4 s";
  EXPECT_GE(10 * stop_found, 9 * stop_rested) << "nine in ten scans at the stop line must be found at rest";
  EXPECT_EQ(s.estimator_counts.at("zero_velocity_updates"), flagged);
}

TEST_F(Stops, CostNoAccuracy) {
  const RunSummary on = run(true, ""), off = run(false, "");
  ASSERT_TRUE(on.error.empty() && off.error.empty());
  const double a_on = ate(on), a_off = ate(off);
  std::cout << "ATE with the update at rest " << a_on << " m, without " << a_off << " m\n";
  // Measured: 4.3 mm with, 4.2 mm without (the roof Mid-360 holds a parked car well; the spinning32
  // on 80 s of this drive with two stops gains 6 %, docs/architecture.md).
  EXPECT_LT(a_on, 1.2 * a_off);
  EXPECT_LT(a_on, 0.02);
}

}  // namespace
}  // namespace fuse

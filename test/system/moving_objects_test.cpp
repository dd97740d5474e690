// Moving objects and the estimate (estimator.map.carve_lookback_s, docs/architecture.md "Moving
// objects and the map"): on 45 s of the urban drive with traffic, the points that lie where an
// earlier scan saw empty space (cars and pedestrians that came in) are found, counted and left
// out of the update and the map, and the trajectory is no worse for it; with the key at 0
// (as shipped) nothing is left out.
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "fuse/eval/evaluate.hpp"
#include "fuse/eval/trajectory.hpp"
#include "runner.hpp"

namespace fuse {
namespace {

const std::string kConfig = std::string(FUSE_CONFIG_DIR) + "/mid360.yaml";
const std::string kData = std::string(FUSE_TEST_DATA) + "/urban45";

double ate(const RunSummary& s) { return eval::evaluate(eval::read_tum(kData + "/groundtruth.tum"), s.trajectory).ate.rmse; }

TEST(MovingObjects, PointsWhereAnEarlierScanSawEmptySpaceAreLeftOutAndTheEstimateKeepsItsAccuracy) {
  if (!std::filesystem::exists(kData + "/recording.mcap")) GTEST_SKIP() << "no " << kData << " (fixture system.sim.urban45)";
  const RunSummary off = run_offline(load_runner_config(kConfig), kData + "/recording.mcap", "");
  const RunSummary on =
      run_offline(load_runner_config(kConfig, {"estimator.map.carve_lookback_s=1"}), kData + "/recording.mcap", "");
  ASSERT_TRUE(off.error.empty() && on.error.empty()) << off.error << on.error;
  ASSERT_FALSE(off.diverged || on.diverged) << off.divergence << on.divergence;
  ASSERT_GT(on.trajectory.size(), 400U);
  const double ate_off = ate(off), ate_on = ate(on);
  std::cout << "moving points left out: " << on.moving_screened << " over " << on.scans << " scans; ATE " << ate_on
            << " m, " << ate_off << " m without\n";
  EXPECT_EQ(off.moving_screened, 0u);
  // 2.4 % of the drive's points are on movers; measured 12,560 left out over the 450 scans.
  EXPECT_GT(on.moving_screened, 5000u);
  EXPECT_LT(ate_on, 1.2 * ate_off);
}

}  // namespace
}  // namespace fuse

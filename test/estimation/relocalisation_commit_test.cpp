// A re-localisation that fits too poorly is not taken (estimator.recovery.commit_fit). Fixture
// with known truth: a box room 20 × 20 × 4 m seen from its centre seeds the map; the next scan
// sees the same floor but otherwise only clutter the map does not have (a few percent of its
// points lie on a mapped plane), from a prior 0.3 m too high with a wide σ. The floor alone pulls
// the height back; the scan as a whole fits a few percent. Taken (commit_fit 0), the history
// moves; not taken (the default), it keeps the prior and the scan is not added to the map.
// Nor is a scan re-localised that was mostly measured during a data gap
// (estimator.recovery.min_measured_fraction).
#include <gtest/gtest.h>

#include <random>

#include "fuse/estimation/lidar_updater.hpp"
#include "test_helpers.hpp"

namespace fuse {
namespace {

constexpr double kHalf = 10.0;  // m: half the room's side
constexpr double kFloor = -1.5, kCeiling = 2.5;

void add(LidarScan& scan, double x, double y, double z) {
  LidarPoint p;
  p.x = static_cast<float>(x);
  p.y = static_cast<float>(y);
  p.z = static_cast<float>(z);
  scan.points.push_back(p);
}

LidarScan floor_points(double t) {
  LidarScan scan;
  scan.t_start = t - 0.1;
  scan.t_end = t;
  for (double x = -kHalf + 0.25; x < kHalf; x += 0.5) {
    for (double y = -kHalf + 0.25; y < kHalf; y += 0.5) add(scan, x, y, kFloor);
  }
  return scan;
}

LidarScan room(double t) {
  LidarScan scan = floor_points(t);
  for (double a = -kHalf + 0.25; a < kHalf; a += 0.5) {
    for (double z = kFloor + 0.25; z < kCeiling; z += 0.5) {
      add(scan, a, -kHalf, z);
      add(scan, a, kHalf, z);
      add(scan, -kHalf, a, z);
      add(scan, kHalf, a, z);
    }
  }
  return scan;
}

LidarScan clutter_over_a_patch_of_floor(double t) {
  LidarScan scan;
  scan.t_start = t - 0.1;
  scan.t_end = t;
  for (double x = 1.25; x < 4.0; x += 0.5) {
    for (double y = 1.25; y < 4.0; y += 0.5) add(scan, x, y, kFloor);  // 36 mapped-floor points
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-6.0, 6.0), h(-0.5, 2.0);
  for (int i = 0; i < 1200; ++i) add(scan, u(rng), u(rng), h(rng));  // unmapped, away from the walls
  return scan;
}

struct Outcome {
  double z_after = 0.0;
  ScanReport report;
};

Outcome relocalise_with(double commit_fit) {
  EstimatorConfig config;
  config.preprocess.deskew = false;
  config.recovery.commit_fit = commit_fit;
  LidarUpdater updater(config);
  StateHistory history = test::rested_history(config.history, config.imu, 0.1);
  updater.process(room(0.1), history);  // seeds the map at the true pose
  EXPECT_GT(updater.map().size(), 0u);
  EXPECT_TRUE(history.ensure_entry(0.2));
  NavState high = history.query(0.2).x;
  high.p.z() += 0.3;
  StateCovariance wide = history.query(0.2).P;
  wide.block<3, 3>(Idx::kPos, Idx::kPos) = Eigen::Matrix3d::Identity();  // σ 1 m: re-localised
  history.correct(0.2, high, wide);
  Outcome r;
  r.report = updater.process(clutter_over_a_patch_of_floor(0.2), history);
  r.z_after = history.query(0.2).x.p.z();
  return r;
}

TEST(RelocalisationCommit, AFitOfAFewPercentIsNotTaken) {
  const Outcome taken = relocalise_with(0.0);
  ASSERT_TRUE(taken.report.recovery);
  ASSERT_TRUE(taken.report.updated) << "the floor alone must give a re-localisation to judge";
  EXPECT_LT(taken.report.fit, 0.2);
  EXPECT_LT(std::abs(taken.z_after), 0.1) << "taken: the floor pulls the height back";

  const Outcome kept = relocalise_with(0.2);
  EXPECT_TRUE(kept.report.recovery);
  EXPECT_FALSE(kept.report.updated);
  EXPECT_NEAR(kept.z_after, 0.3, 1e-9) << "not taken: the prior stays";
  EXPECT_EQ(kept.report.map_inserted, 0u);
}

/// The room seen at 1.05 s after a data gap that ended at 1.0 s (the IMU resumed there), with
/// `in_gap` of its points stamped before the gap's end (cut: nothing measured the motion that
/// would deskew them), from a prior re-localisation must search (σ 1 m).
struct GapOutcome {
  ScanReport report;
  std::uint64_t mostly_in_gap = 0;  ///< counter recovery_scan_mostly_in_gap
  std::uint64_t points_cut = 0;     ///< counter scan_points_in_data_gap
};

GapOutcome after_gap(double min_measured_fraction, double in_gap) {
  EstimatorConfig config;
  config.preprocess.deskew = false;
  config.recovery.min_measured_fraction = min_measured_fraction;
  LidarUpdater updater(config);
  StateHistory history = test::rested_history(config.history, config.imu, 0.1);
  updater.process(room(0.1), history);
  for (double t = 1.0; t < 1.0501; t += 0.005) history.add_imu(test::at_rest(t));  // the gap [0.1, 1.0], then the IMU
  EXPECT_TRUE(history.ensure_entry(1.05));
  StateCovariance wide = history.query(1.05).P;
  wide.block<3, 3>(Idx::kPos, Idx::kPos) = Eigen::Matrix3d::Identity();
  history.correct(1.05, history.query(1.05).x, wide);
  LidarScan scan = room(1.05);
  scan.t_start = 0.95;
  for (std::size_t i = 0; i < scan.points.size(); ++i) {
    // Spread over the scan: a fraction in_gap of the points before 1.0 s (t_rel < 0.05).
    const double u = static_cast<double>(i % 100) / 100.0;
    scan.points[i].t_rel = static_cast<float>(u < in_gap ? 0.049 * u / in_gap : 0.0505 + 0.049 * (u - in_gap));
  }
  GapOutcome out;
  out.report = updater.process(scan, history);
  out.mostly_in_gap = updater.counters().get("recovery_scan_mostly_in_gap");
  out.points_cut = updater.counters().get("scan_points_in_data_gap");
  return out;
}

// A scan mostly measured during a data gap keeps only a sliver of the scene after the cut, which
// fits a wrong place as well as the right one: it is not re-localised, counted, and the prior
// stays for the next scan (estimator.recovery.min_measured_fraction). A scan measured mostly
// after the gap is re-localised on what is left.
TEST(RelocalisationCommit, AScanMostlyMeasuredInADataGapIsNotReLocalised) {
  const GapOutcome sliver = after_gap(0.5, 0.95);
  EXPECT_TRUE(sliver.report.recovery);
  EXPECT_FALSE(sliver.report.updated);
  EXPECT_EQ(sliver.report.map_inserted, 0u);
  EXPECT_EQ(sliver.mostly_in_gap, 1u);
  EXPECT_EQ(sliver.points_cut, 1u);  // counted once per scan

  const GapOutcome without_rule = after_gap(0.0, 0.95);
  EXPECT_TRUE(without_rule.report.recovery);
  EXPECT_TRUE(without_rule.report.updated) << "without the rule the sliver is re-localised";
  const GapOutcome most_measured = after_gap(0.5, 0.3);
  EXPECT_TRUE(most_measured.report.recovery);
  EXPECT_TRUE(most_measured.report.updated);
  EXPECT_EQ(most_measured.mostly_in_gap, 0u);
  EXPECT_EQ(most_measured.points_cut, 1u);
}

}  // namespace
}  // namespace fuse

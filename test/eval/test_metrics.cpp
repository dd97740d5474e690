// Metrics with known truth: statistics, evo's path pairs, RPE of a constant drift, terminal
// drift and end-to-end error of a synthetic closed loop.
#include <gtest/gtest.h>

#include "fuse/eval/metrics.hpp"
#include "fuse/eval/scan_times.hpp"
#include "test_helpers.hpp"

namespace fuse::eval {
namespace {

constexpr double kStep = 0.25;  // m between poses; exact in binary, so path sums are exact

/// A straight line along x, pose i at i * kStep metres, the body turned by `yaw` about z.
Trajectory line(int n, double yaw) {
  const Eigen::Quaterniond q(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  Trajectory out;
  for (int i = 0; i < n; ++i) {
    StampedPose pose;
    pose.t = i;
    pose.q = q;
    pose.p = Eigen::Vector3d(kStep * i, 0.0, 0.0);
    out.push_back(pose);
  }
  return out;
}

TEST(ScanTimes, RanksOfTheTailAreTakenFromTheSortedTimes) {
  // 1..200 ms shuffled: the value at rank floor(q n) of the sorted times.
  std::vector<double> ms;
  for (int i = 0; i < 200; ++i) ms.push_back((i * 7) % 200 + 1);  // 7 is coprime with 200
  const TimeStatistics s = time_statistics(ms);
  EXPECT_DOUBLE_EQ(s.mean_ms, 100.5);
  EXPECT_DOUBLE_EQ(s.median_ms, 101.0);
  EXPECT_DOUBLE_EQ(s.p95_ms, 191.0);
  EXPECT_DOUBLE_EQ(s.p99_ms, 199.0);
  EXPECT_DOUBLE_EQ(s.max_ms, 200.0);
  const TimeStatistics none = time_statistics({});
  EXPECT_EQ(none.max_ms, 0.0);
  EXPECT_EQ(none.median_ms, 0.0);
}

TEST(Metrics, StatisticsMatchNumpy) {
  const ErrorStatistics s = compute_statistics({4.0, 1.0, 3.0, 2.0});
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);  // even count: mean of the two middle values
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));  // population std (ddof = 0)
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  EXPECT_DOUBLE_EQ(s.sse, 30.0);
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(compute_statistics({5.0, 1.0, 3.0}).median, 3.0);
  EXPECT_THROW(compute_statistics({}), std::invalid_argument);
}

TEST(Metrics, PathPairsFollowEvoConsecutiveRule) {
  // 1 m at 0.25 m per pose: the sum reaches 1 m at index 4, 8, 12, ... (index 0 is not kept).
  const IdPairs pairs = pairs_by_path(line(21, 0.0), 1.0);
  ASSERT_EQ(pairs.size(), 4u);
  EXPECT_EQ(pairs[0], std::make_pair(std::size_t{4}, std::size_t{8}));
  EXPECT_EQ(pairs[3], std::make_pair(std::size_t{16}, std::size_t{20}));
  EXPECT_TRUE(pairs_by_path(line(21, 0.0), 10.0).empty());
  EXPECT_THROW(pairs_by_path(line(3, 0.0), 0.0), std::invalid_argument);
  EXPECT_THROW(pairs_by_path(line(3, 0.0), std::nan("")), std::invalid_argument);
}

TEST(Metrics, RpeOfConstantDriftIsDriftTimesPairSpan) {
  // The estimate drifts by a constant velocity bias b per pose: over a pair (i, j) the relative
  // translation error is (j - i) b, whatever the heading.
  const Eigen::Vector3d bias(0.003, -0.004, 0.012);  // |b| = 0.013 m per pose
  const Trajectory ref = line(41, 0.7);
  Trajectory est = ref;
  for (std::size_t i = 0; i < est.size(); ++i) est[i].p += static_cast<double>(i) * bias;
  const IdPairs pairs = pairs_by_path(ref, 1.0);
  const std::vector<double> errors = rpe_translation_errors(ref, est, pairs);
  ASSERT_EQ(errors.size(), 9u);
  for (const double e : errors) EXPECT_NEAR(e, 4.0 * bias.norm(), 1e-12);
  // Unaligned by design: a rigid motion of the whole estimate does not change the RPE.
  const Eigen::Quaterniond R(Eigen::AngleAxisd(1.0, Eigen::Vector3d(1, 1, 0).normalized()));
  Trajectory moved = est;
  for (StampedPose& pose : moved) {
    pose.p = R * pose.p + Eigen::Vector3d(5, -2, 1);
    pose.q = R * pose.q;
  }
  const std::vector<double> moved_errors = rpe_translation_errors(ref, moved, pairs);
  for (std::size_t k = 0; k < errors.size(); ++k) EXPECT_NEAR(moved_errors[k], errors[k], 1e-12);
}

TEST(Metrics, RpeSeesHeadingErrorAsTranslationError) {
  // Estimate rotated by a constant yaw error relative to its motion: over 1 m the relative
  // translation error is the chord 2 sin(θ/2).
  const double theta = 0.05;
  const Trajectory ref = line(9, 0.0);
  Trajectory est = ref;
  for (StampedPose& pose : est) pose.q = Eigen::Quaterniond(Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()));
  const std::vector<double> errors = rpe_translation_errors(ref, est, {{4, 8}});
  EXPECT_NEAR(errors[0], 2.0 * std::sin(theta / 2.0), 1e-12);
}

TEST(Metrics, RotationErrorsAreAnglesInDegrees) {
  // APE: every estimate pose turned 2° about an arbitrary axis against its reference pose.
  const Trajectory ref = line(13, 0.3);
  Trajectory est = ref;
  const Eigen::Quaterniond tilt(Eigen::AngleAxisd(2.0 * EIGEN_PI / 180.0, Eigen::Vector3d(1, 2, 3).normalized()));
  for (StampedPose& pose : est) pose.q = pose.q * tilt;
  for (const double e : ape_rotation_errors_deg(ref, est)) EXPECT_NEAR(e, 2.0, 1e-9);
  // RPE: a yaw rate error of 0.5° per pose gives (j - i) * 0.5° over a pair; a constant turn, none.
  Trajectory drifting = ref;
  for (std::size_t i = 0; i < drifting.size(); ++i) {
    drifting[i].q = Eigen::Quaterniond(Eigen::AngleAxisd(0.5 * EIGEN_PI / 180.0 * static_cast<double>(i),
                                                         Eigen::Vector3d::UnitZ())) * drifting[i].q;
  }
  const std::vector<double> rpe = rpe_rotation_errors_deg(ref, drifting, {{2, 6}, {6, 12}});
  EXPECT_NEAR(rpe[0], 2.0, 1e-9);
  EXPECT_NEAR(rpe[1], 3.0, 1e-9);
  for (const double e : rpe_rotation_errors_deg(ref, est, {{0, 12}})) EXPECT_NEAR(e, 0.0, 1e-9);
  est.pop_back();
  EXPECT_THROW(ape_rotation_errors_deg(ref, est), std::invalid_argument);
}

TEST(Metrics, ApeIsPositionDistance) {
  Trajectory ref = line(3, 0.0);
  Trajectory est = ref;
  est[1].p += Eigen::Vector3d(0.3, 0.4, 0.0);
  const std::vector<double> e = ape_translation_errors(ref, est);
  EXPECT_DOUBLE_EQ(e[0], 0.0);
  EXPECT_DOUBLE_EQ(e[1], 0.5);
  est.pop_back();
  EXPECT_THROW(ape_translation_errors(ref, est), std::invalid_argument);
}

TEST(Metrics, ClosedLoopEndToEndAndTerminalDrift) {
  constexpr int kPoses = 201;
  constexpr double kRadius = 10.0;
  const Trajectory gt = test::circle(kRadius, kPoses);
  EXPECT_NEAR(end_to_end_distance(gt), 0.0, 1e-12);
  // Polygon of kPoses - 1 chords around the circle.
  const double chords = (kPoses - 1) * 2.0 * kRadius * std::sin(M_PI / (kPoses - 1));
  EXPECT_NEAR(path_length(gt), chords, 1e-9);

  // The estimate accumulates a position error d and a rotation error R_d linearly along the loop.
  const Eigen::Vector3d d(0.3, -0.4, 1.2);  // |d| = 1.3 m
  const double yaw = 2.0, pitch = -1.0, roll = 0.5;  // degrees at the end
  Trajectory est = gt;
  for (int i = 0; i < kPoses; ++i) {
    const double f = static_cast<double>(i) / (kPoses - 1);
    const Eigen::Matrix3d R_d = (Eigen::AngleAxisd(f * yaw * M_PI / 180, Eigen::Vector3d::UnitZ()) *
                                 Eigen::AngleAxisd(f * pitch * M_PI / 180, Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(f * roll * M_PI / 180, Eigen::Vector3d::UnitX()))
                                    .toRotationMatrix();
    est[i].p += f * d;
    est[i].q = Eigen::Quaterniond(R_d) * gt[i].q;
  }
  EXPECT_NEAR(end_to_end_distance(est), 1.3, 1e-9);

  // Aligning the first poses is a no-op here (they agree), so the drift is exactly d and R_d(1).
  TerminalDrift drift = terminal_drift(gt, est);
  EXPECT_LT((drift.translation_m - d).norm(), 1e-9);
  EXPECT_NEAR(drift.translation_norm_m, 1.3, 1e-9);
  EXPECT_NEAR(drift.yaw_deg, yaw, 1e-9);
  EXPECT_NEAR(drift.pitch_deg, pitch, 1e-9);
  EXPECT_NEAR(drift.roll_deg, roll, 1e-9);

  // Moving the whole estimate rigidly (a different start frame) leaves the drift unchanged.
  const Eigen::Quaterniond R(Eigen::AngleAxisd(0.8, Eigen::Vector3d(0.2, -1, 0.3).normalized()));
  Trajectory moved = est;
  for (StampedPose& pose : moved) {
    pose.p = R * pose.p + Eigen::Vector3d(100, 50, -3);
    pose.q = R * pose.q;
  }
  drift = terminal_drift(gt, moved);
  EXPECT_LT((drift.translation_m - d).norm(), 1e-9);
  EXPECT_NEAR(drift.yaw_deg, yaw, 1e-9);
  EXPECT_NEAR(drift.roll_deg, roll, 1e-9);
}

}  // namespace
}  // namespace fuse::eval

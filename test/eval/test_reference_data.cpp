// Real trajectories from the shared data (evo's test data): the numbers evo prints.
#include <gtest/gtest.h>

#include <filesystem>

#include "fuse/eval/evaluate.hpp"

namespace fuse::eval {
namespace {

const std::string kTrajectories = std::string(FUSE_SHARED_DATA) + "/trajectories/";

/// evo_ape kitti KITTI_00_gt.txt KITTI_00_ORB.txt -a  ->  rmse 1.3034 (the oracle figure).
constexpr double kEvoKittiOrbApeRmse = 1.3034;
constexpr double kOracleTolerance = 1e-3;

#define SKIP_WITHOUT(file)                                                                       \
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "shared test data absent: " << (file)

TEST(ReferenceData, KittiOrbApeMatchesEvoWithSe3Alignment) {
  const std::string gt_path = kTrajectories + "KITTI_00_gt.txt";
  const std::string est_path = kTrajectories + "KITTI_00_ORB.txt";
  SKIP_WITHOUT(gt_path);
  const Trajectory gt = read_kitti(gt_path);
  const Trajectory est = read_kitti(est_path);
  ASSERT_EQ(gt.size(), 4541u);
  EvaluationConfig config;
  config.association = AssociationMode::kIndex;
  config.alignment = AlignmentMode::kSE3;
  const EvaluationResult se3 = evaluate(gt, est, config);
  EXPECT_EQ(se3.matched_poses, 4541u);
  EXPECT_NEAR(se3.ate.rmse, kEvoKittiOrbApeRmse, kOracleTolerance);

  // Sim(3) (evo_ape -as) gives a clearly different figure: the oracle is the SE(3) one.
  config.alignment = AlignmentMode::kSim3;
  const EvaluationResult sim3 = evaluate(gt, est, config);
  EXPECT_GT(std::abs(sim3.ate.rmse - kEvoKittiOrbApeRmse), 0.1);
  EXPECT_NE(sim3.alignment.scale, 1.0);
}

TEST(ReferenceData, KittiTimesFileGivesTimestamps) {
  const std::string gt_path = kTrajectories + "KITTI_00_gt.txt";
  const std::string times_path = kTrajectories + "KITTI_00_gt_times.txt";
  SKIP_WITHOUT(times_path);
  const Trajectory gt = read_kitti(gt_path, times_path);
  ASSERT_EQ(gt.size(), 4541u);
  EXPECT_NEAR(gt[1].t, 0.1037359, 1e-7);
  // KITTI 00 is about 3.7 km long.
  EXPECT_NEAR(path_length(gt), 3724.0, 10.0);
}

TEST(ReferenceData, TumFr2DeskOrbSanity) {
  const std::string gt_path = kTrajectories + "fr2_desk_groundtruth.txt";
  const std::string est_path = kTrajectories + "fr2_desk_ORB.txt";
  SKIP_WITHOUT(gt_path);
  const Trajectory gt = read_tum(gt_path);
  const Trajectory est = read_tum(est_path);
  EXPECT_EQ(gt.size(), 20956u);  // 20957 lines, one repeated timestamp dropped
  EXPECT_EQ(est.size(), 2893u);

  // evo's associate_trajectories finds 2174 matches with --t_max_diff 0.01; the estimate stamp
  // 1311868220.91065 lies as far from 1311868220.909 as from 1311868220.9123 and takes the first.
  const AssociatedTrajectories matched = associate_by_time(gt, est, kDefaultMaxTimeDifference);
  ASSERT_EQ(matched.reference.size(), 2174u);
  bool tie_found = false;
  for (std::size_t i = 0; i < matched.estimate.size(); ++i) {
    if (std::abs(matched.estimate[i].t - 1311868220.91065) < 1e-6) {
      EXPECT_NEAR(matched.reference[i].t, 1311868220.909, 1e-6);
      tie_found = true;
    }
  }
  EXPECT_TRUE(tie_found);

  // An RGB-D ORB-SLAM run on a desk scene: ATE of millimetres to a few centimetres.
  const EvaluationResult r = evaluate(gt, est);
  EXPECT_EQ(r.matched_poses, 2174u);
  EXPECT_GT(r.ate.rmse, 0.001);
  EXPECT_LT(r.ate.rmse, 0.03);
  ASSERT_TRUE(r.rpe.has_value());
  EXPECT_LT(r.rpe->rmse, 0.05);
  EXPECT_GT(r.path_length_m, 10.0);
}

}  // namespace
}  // namespace fuse::eval

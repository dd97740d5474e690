// evaluate(): alignment choice, RPE presence, configuration checks and output formats.
#include <gtest/gtest.h>

#include "fuse/eval/evaluate.hpp"
#include "test_helpers.hpp"

namespace fuse::eval {
namespace {

/// A helix (not planar, so SE(3)/Sim(3) alignment is well-posed).
Trajectory helix(int n) {
  Trajectory out = test::circle(5.0, n);
  for (int i = 0; i < n; ++i) out[i].p.z() = 0.02 * i;
  return out;
}

Trajectory similarity_of(const Trajectory& t, double scale) {
  Similarity3 T;
  T.rotation = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T.translation = Eigen::Vector3d(3, -1, 2);
  T.scale = scale;
  return transform(t, T);
}

TEST(Evaluate, Se3AlignedAteOfRigidlyMovedGroundTruthIsZero) {
  const Trajectory gt = helix(101);
  const EvaluationResult r = evaluate(gt, similarity_of(gt, 1.0));
  EXPECT_EQ(r.matched_poses, 101u);
  EXPECT_LT(r.ate.rmse, 1e-9);
  ASSERT_TRUE(r.rpe.has_value());
  EXPECT_LT(r.rpe->rmse, 1e-9);
  EXPECT_LT(r.drift.translation_norm_m, 1e-9);
  EXPECT_NEAR(r.path_length_m, r.estimate_path_length_m, 1e-9);

  EvaluationConfig unaligned;
  unaligned.alignment = AlignmentMode::kNone;
  EXPECT_GT(evaluate(gt, similarity_of(gt, 1.0), unaligned).ate.rmse, 1.0);
}

TEST(Evaluate, Sim3AlignmentRemovesScale) {
  const Trajectory gt = helix(101);
  const Trajectory est = similarity_of(gt, 0.5);
  EvaluationConfig sim3;
  sim3.alignment = AlignmentMode::kSim3;
  const EvaluationResult r = evaluate(gt, est, sim3);
  EXPECT_LT(r.ate.rmse, 1e-9);
  EXPECT_NEAR(r.alignment.scale, 2.0, 1e-9);
  EXPECT_GT(evaluate(gt, est).ate.rmse, 0.5);  // SE(3) cannot undo the scale
}

TEST(Evaluate, IndexAssociationIgnoresTimestamps) {
  const Trajectory gt = helix(50);
  Trajectory est = gt;
  for (StampedPose& pose : est) pose.t += 1000.0;
  EXPECT_THROW(evaluate(gt, est), std::runtime_error);  // timestamps do not match
  EvaluationConfig by_index;
  by_index.association = AssociationMode::kIndex;
  EXPECT_EQ(evaluate(gt, est, by_index).matched_poses, 50u);
}

TEST(Evaluate, ShortPathHasNoRpeButOtherMetrics) {
  const Trajectory gt = helix(10);  // about 31 m of path
  EvaluationConfig config;
  config.rpe_delta_m = 20.0;  // one index is kept, so no pair
  const EvaluationResult r = evaluate(gt, gt, config);
  EXPECT_FALSE(r.rpe.has_value());
  const std::string json = format_json(r);
  EXPECT_NE(json.find("\"rpe_trans_rmse_m\": null"), std::string::npos) << json;
  EXPECT_NE(json.find("\"rpe_pairs\": 0"), std::string::npos) << json;
  EXPECT_NE(format_text(r).find("rpe_trans_rmse_m: nan\n"), std::string::npos);
}

TEST(Evaluate, RejectsBadConfigAndTooFewMatches) {
  const Trajectory gt = helix(10);
  EvaluationConfig bad_delta;
  bad_delta.rpe_delta_m = -1.0;
  EXPECT_THROW(evaluate(gt, gt, bad_delta), std::invalid_argument);
  EvaluationConfig bad_dt;
  bad_dt.max_time_difference = std::nan("");
  EXPECT_THROW(evaluate(gt, gt, bad_dt), std::invalid_argument);
  Trajectory with_nan = gt;
  with_nan[4].p.y() = std::nan("");
  EXPECT_THROW(evaluate(gt, with_nan), std::invalid_argument);
  const Trajectory two(gt.begin(), gt.begin() + 2);
  EXPECT_THROW(evaluate(two, two), std::runtime_error);
  Trajectory collinear = gt;
  for (std::size_t i = 0; i < collinear.size(); ++i) collinear[i].p = Eigen::Vector3d(static_cast<double>(i), 0, 0);
  EXPECT_THROW(evaluate(collinear, collinear), std::runtime_error);
}

TEST(Evaluate, TextOutputHasEveryNamedField) {
  const Trajectory gt = helix(101);
  const std::string text = format_text(evaluate(gt, gt));
  for (const char* name : {"ate_rmse_m: ", "ate_mean_m: ", "ate_max_m: ", "rpe_trans_rmse_m: ", "end_to_end_m: ",
                           "drift_x_m: ", "drift_y_m: ", "drift_z_m: ", "drift_yaw_deg: ", "drift_pitch_deg: ",
                           "drift_roll_deg: ", "drift_percent: ", "path_length_m: ", "matched_poses: 101\n"}) {
    EXPECT_NE(text.find(name), std::string::npos) << name;
  }
}

}  // namespace
}  // namespace fuse::eval

// The LiDAR-IMU extrinsic online (estimator.estimate_extrinsic, docs/architecture.md "LiDAR-IMU
// extrinsic online"), given 3° and 5 cm wrong: the room's handheld turns about every axis must
// bring it back within 0.5° and 2 cm of the truth (the recording's own calibration) in 20 s, and
// the trajectory must be better for it; on a car's drive, which turns about the vertical only, the estimator
// must notice that the motion does not excite it and hold the extrinsic where it was given
// instead of letting it drift: all of it (one_axis: hold), or all but the LiDAR's tilt against
// the turn axis, which the turns do show (one_axis: tilt, as shipped).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "fuse/core/so3.hpp"
#include "fuse/eval/evaluate.hpp"
#include "fuse/eval/trajectory.hpp"
#include "runner.hpp"

namespace fuse {
namespace {

const std::string kConfig = std::string(FUSE_CONFIG_DIR) + "/mid360.yaml";
constexpr double kDeg = M_PI / 180.0;

std::string recording(const std::string& name) { return std::string(FUSE_TEST_DATA) + "/" + name + "/recording.mcap"; }

/// The recording's own extrinsic (its calibration record): a run that does not estimate it ends
/// with the one it was given.
RunSummary truth_run(const std::string& name) {
  return run_offline(load_runner_config(kConfig), recording(name), "");
}

/// The truth made wrong by `deg` about (1, −1, 1)/√3 on the LiDAR side and `cm` along the same axis.
Eigen::Isometry3d wrong(const RunSummary& truth, double deg, double cm) {
  const Eigen::Vector3d axis = Eigen::Vector3d(1.0, -1.0, 1.0).normalized();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = truth.R_IL * so3::Exp(axis * deg * kDeg);
  T.translation() = truth.p_IL + axis * cm * 0.01;
  return T;
}

RunSummary run_given(const std::string& name, const Eigen::Isometry3d& T_imu_lidar, bool estimate,
                     std::vector<std::string> sets = {}) {
  sets.push_back(std::string("estimator.estimate_extrinsic=") + (estimate ? "true" : "false"));
  sets.push_back("estimator.initial_covariance.extrinsic_rotation_std=0.0524");  // 3°: as wrong as it is
  sets.push_back("estimator.initial_covariance.extrinsic_translation_std=0.05");
  RunnerConfig config = load_runner_config(kConfig, sets);
  config.extrinsic_from = "config";
  config.estimator.T_imu_lidar = T_imu_lidar;
  return run_offline(config, recording(name), "");
}

double rotation_error_deg(const RunSummary& a, const RunSummary& b) {
  return so3::Log(a.R_IL.transpose() * b.R_IL).norm() / kDeg;
}
double translation_error_cm(const RunSummary& a, const RunSummary& b) { return (a.p_IL - b.p_IL).norm() * 100.0; }

double ate(const std::string& name, const RunSummary& s) {
  return eval::evaluate(eval::read_tum(std::string(FUSE_TEST_DATA) + "/" + name + "/groundtruth.tum"), s.trajectory).ate.rmse;
}

TEST(Extrinsic, ConvergesWhereTheSensorTurnsAboutEveryAxis) {
  const std::string room = "room20_offset0";
  if (!std::filesystem::exists(recording(room))) GTEST_SKIP() << "no simulated room data (the fuse_sim_data fixture)";
  const RunSummary truth = truth_run(room);
  ASSERT_TRUE(truth.error.empty()) << truth.error;
  const Eigen::Isometry3d given = wrong(truth, 3.0, 5.0);
  const RunSummary estimated = run_given(room, given, true), fixed = run_given(room, given, false);
  ASSERT_TRUE(estimated.error.empty() && fixed.error.empty());
  ASSERT_GT(estimated.trajectory.size(), 100U);
  ASSERT_NEAR(rotation_error_deg(truth, fixed), 3.0, 1e-6) << "the extrinsic given is 3° wrong";
  const double rot = rotation_error_deg(truth, estimated), trans = translation_error_cm(truth, estimated);
  std::cout << "room, 20 s: estimate " << rot << " deg / " << trans << " cm from the truth; ATE " << ate(room, estimated)
            << " m (held at the wrong one: " << ate(room, fixed) << " m, true one: " << ate(room, truth) << " m)\n";
  // Measured: 0.34° / 0.3 cm; ATE 2.3 cm against 3.3 cm held at the wrong one and 0.6 cm with the
  // true one (the map built in the first seconds, with the extrinsic still wrong, stays).
  EXPECT_LT(rot, 0.5);
  EXPECT_LT(trans, 2.0);
  EXPECT_LT(ate(room, estimated), 0.85 * ate(room, fixed)) << "estimating it must help the trajectory";
}

TEST(Extrinsic, IsHeldWhereTheMotionDoesNotExciteIt) {
  const std::string urban = "urban45";
  if (!std::filesystem::exists(recording(urban))) GTEST_SKIP() << "no simulated urban data (the fuse_sim_data fixture)";
  const RunSummary truth = truth_run(urban);
  ASSERT_TRUE(truth.error.empty()) << truth.error;
  const Eigen::Isometry3d given = wrong(truth, 3.0, 5.0);
  // As shipped (one_axis: tilt): the tilt against the vertical turn is estimated, the rest held.
  const RunSummary tilt = run_given(urban, given, true);
  const RunSummary held = run_given(urban, given, true, {"estimator.extrinsic_excitation.one_axis=hold"});
  // With the excitation check off: what holding prevents.
  const RunSummary free = run_given(urban, given, true, {"estimator.extrinsic_excitation.min_rate_deg_s=0"});
  const RunSummary fixed = run_given(urban, given, false);
  ASSERT_TRUE(tilt.error.empty() && held.error.empty() && free.error.empty() && fixed.error.empty());
  const auto count = [](const RunSummary& s, const char* reason = "extrinsic_held_weak_excitation") {
    const auto it = s.estimator_counts.find(reason);
    return it == s.estimator_counts.end() ? std::uint64_t{0} : it->second;
  };
  const auto moved_deg = [&](const RunSummary& s) { return so3::Log(given.linear().transpose() * s.R_IL).norm() / kDeg; };
  const auto moved_cm = [&](const RunSummary& s) { return (s.p_IL - given.translation()).norm() * 100.0; };
  std::cout << "urban, 45 s: held on " << count(held) << " of " << held.scans_updated << " updated scans (tilt estimated on "
            << count(tilt, "extrinsic_held_but_tilt") << " of " << tilt.scans_updated << "); one_axis hold: moved "
            << moved_deg(held) << " deg / " << moved_cm(held) << " cm; tilt: " << rotation_error_deg(truth, tilt)
            << " deg from the truth (given 3), moved " << moved_cm(tilt) << " cm, ATE " << ate(urban, tilt)
            << " m against " << ate(urban, fixed) << " m not estimated; never held: moved " << moved_deg(free) << " deg / "
            << moved_cm(free) << " cm\n";
  // Measured: held on 440 of 440; hold moves nothing; tilt 2.45° from the truth (its part about the
  // vertical, 1.73°, is not seen), 2e-9 m, ATE 4.6 against 6.3 cm; never held: 0.64° and 4.7 cm moved.
  EXPECT_GE(count(held), held.scans_updated) << "every updated scan holds it";
  EXPECT_EQ(count(held, "extrinsic_held_but_tilt"), 0U) << "one_axis hold holds it whole";
  // Measured: the tilt estimated on 139 of 440 (while the car turns at 3°/s or more).
  EXPECT_GT(count(tilt, "extrinsic_held_but_tilt"), tilt.scans_updated / 10) << "the car turns: the tilt is estimated";
  EXPECT_LE(count(tilt, "extrinsic_held_but_tilt"), count(tilt)) << "a tilt-only hold is a hold";
  EXPECT_LT(moved_deg(held), 1e-6);
  EXPECT_LT(moved_cm(held), 1e-7);
  EXPECT_LT(moved_cm(tilt), 0.01) << "the translation is held while the motion turns about one axis";
  EXPECT_LT(rotation_error_deg(truth, tilt), 3.0) << "the tilt, seen by the turns, comes closer to the truth";
  EXPECT_LT(ate(urban, tilt), ate(urban, fixed));
  EXPECT_GT(moved_deg(free) + moved_cm(free), 0.01) << "without the check, the data must move the extrinsic (or holding tests nothing)";
}

}  // namespace
}  // namespace fuse

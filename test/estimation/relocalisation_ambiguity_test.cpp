// An ambiguous re-localisation is flagged (estimator.recovery.ambiguity_angle, ambiguity_fit).
// Fixture with known truth: a rectangular room 20 × 12 × 4 m, symmetric under a half turn, with
// one pillar that breaks the symmetry, seeds the map from its centre. The next scan is taken from
// the same place turned by a half turn, from a prior that still holds the old heading with a wide
// heading σ (a gap that hid the turn). The right heading fits every point; the prior's heading fits
// the room too, only the pillar's points land in free space. A pillar 1.75 m wide: the turn is
// taken (better by more than recovery.heading_margin) and flagged (the prior's heading fitted
// within recovery.ambiguity_fit; 1.5–2 m do so here, 1 m is too small to turn, 2.5 m tells the
// turn clearly). A pillar 4 m wide: taken and not flagged.
#include <gtest/gtest.h>

#include <cmath>

#include "fuse/estimation/lidar_updater.hpp"
#include "test_helpers.hpp"

namespace fuse {
namespace {

constexpr double kHalfX = 10.0, kHalfY = 6.0;  // m
constexpr double kFloor = -1.5, kCeiling = 2.5;
constexpr double kStep = 0.5;                   // m: spacing of the room's points
const Eigen::Vector2d kPillar(6.0, 3.0);         // m: the pillar's centre (its mirror image is free space)

/// The room and a square pillar of side `pillar` (m), in the frame of a sensor at the room's centre
/// turned by yaw about the vertical.
LidarScan room_with_pillar(double t, double pillar, double yaw) {
  LidarScan scan;
  scan.t_start = t - 0.1;
  scan.t_end = t;
  const Eigen::Matrix3d R_lidar_world = Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  auto add = [&](double x, double y, double z) {
    const Eigen::Vector3d p = R_lidar_world * Eigen::Vector3d(x, y, z);
    LidarPoint q;
    q.x = static_cast<float>(p.x());
    q.y = static_cast<float>(p.y());
    q.z = static_cast<float>(p.z());
    scan.points.push_back(q);
  };
  for (double x = -kHalfX + kStep / 2; x < kHalfX; x += kStep) {
    for (double y = -kHalfY + kStep / 2; y < kHalfY; y += kStep) add(x, y, kFloor);
  }
  for (double z = kFloor + kStep / 2; z < kCeiling; z += kStep) {
    for (double x = -kHalfX + kStep / 2; x < kHalfX; x += kStep) {
      add(x, -kHalfY, z);
      add(x, kHalfY, z);
    }
    for (double y = -kHalfY + kStep / 2; y < kHalfY; y += kStep) {
      add(-kHalfX, y, z);
      add(kHalfX, y, z);
    }
    const double h = pillar / 2;
    for (double a = -h + kStep / 4; a < h; a += kStep / 2) {  // its four faces, densely
      add(kPillar.x() + a, kPillar.y() - h, z);
      add(kPillar.x() + a, kPillar.y() + h, z);
      add(kPillar.x() - h, kPillar.y() + a, z);
      add(kPillar.x() + h, kPillar.y() + a, z);
    }
  }
  return scan;
}

struct Outcome {
  ScanReport report;
  double yaw_after = 0.0;  // rad
};

Outcome relocalise_half_turn(double pillar) {
  EstimatorConfig config;
  config.preprocess.deskew = false;
  LidarUpdater updater(config);
  StateHistory history = test::rested_history(config.history, config.imu, 0.1);
  updater.process(room_with_pillar(0.1, pillar, 0.0), history);  // seeds the map at the true pose
  EXPECT_TRUE(history.ensure_entry(0.2));
  StateCovariance wide = history.query(0.2).P;
  wide.block<3, 3>(Idx::kPos, Idx::kPos) = Eigen::Matrix3d::Identity() * 0.25;  // σ 0.5 m
  wide(Idx::kRot + 2, Idx::kRot + 2) = 4.0;                                       // heading σ 2 rad
  history.correct(0.2, history.query(0.2).x, wide);
  Outcome r;
  r.report = updater.process(room_with_pillar(0.2, pillar, M_PI), history);
  const Eigen::Matrix3d R = history.query(0.2).x.R;
  r.yaw_after = std::atan2(R(1, 0), R(0, 0));
  return r;
}

TEST(RelocalisationAmbiguity, AHalfTurnThatOnlyANarrowPillarTellsIsTakenAndFlagged) {
  const Outcome narrow = relocalise_half_turn(1.75);
  ASSERT_TRUE(narrow.report.recovery);
  ASSERT_TRUE(narrow.report.updated);
  EXPECT_NEAR(std::abs(narrow.yaw_after), M_PI, 0.05) << "the right heading is taken";
  EXPECT_TRUE(narrow.report.ambiguous) << "fit " << narrow.report.fit << ", the prior's heading " << narrow.report.rival_fit;
  EXPECT_GE(narrow.report.rival_fit, narrow.report.fit - EstimatorConfig{}.recovery.ambiguity_fit);
  EXPECT_NEAR(std::abs(narrow.report.rival_heading), M_PI, 0.1);
}

TEST(RelocalisationAmbiguity, AHalfTurnThatAWidePillarTellsIsNotFlagged) {
  const Outcome wide = relocalise_half_turn(4.0);
  ASSERT_TRUE(wide.report.recovery);
  ASSERT_TRUE(wide.report.updated);
  EXPECT_NEAR(std::abs(wide.yaw_after), M_PI, 0.05) << "the right heading is taken";
  EXPECT_FALSE(wide.report.ambiguous) << "fit " << wide.report.fit << ", a rival " << wide.report.rival_fit;
}

}  // namespace
}  // namespace fuse

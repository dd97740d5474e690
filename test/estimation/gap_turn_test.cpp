// LidarUpdater::turned: a heading hypothesis after a coasted gap is a constant-rate turn taken
// during the gap. Oracle: circle geometry. A vehicle that coasted a displacement c straight ahead
// but in truth turned by ψ at a constant rate drove an arc of length |c| and radius |c|/ψ.
#include <gtest/gtest.h>

#include <cmath>

#include "fuse/estimation/lidar_updater.hpp"

namespace fuse {
namespace {

const Eigen::Vector3d kUp = Eigen::Vector3d::UnitZ();

NavState coasted_prior() {
  NavState x;
  x.p = Eigen::Vector3d(2.0, 0.0, 0.0);  // coasted 2 m along +x through the gap, then 0.5 m more
  x.p.x() += 0.5;
  x.v = Eigen::Vector3d(1.0, 0.0, 0.0);
  return x;
}

TEST(GapTurn, QuarterTurnEndsOnTheQuarterArc) {
  const LidarUpdater::CoastedGap gap{Eigen::Vector3d::Zero(), Eigen::Vector3d(2.0, 0.0, 0.0)};
  const double psi = M_PI / 2.0;
  const NavState x = LidarUpdater::turned(coasted_prior(), gap, psi, kUp);
  // The arc from the origin heading +x, turning left by 90°: radius r = 2/(π/2); it ends at (r, r),
  // heading +y, and the 0.5 m measured after the gap continue along +y.
  const double r = 2.0 / psi;
  EXPECT_NEAR(x.p.x(), r, 1e-9);
  EXPECT_NEAR(x.p.y(), r + 0.5, 1e-9);
  EXPECT_NEAR(x.p.z(), 0.0, 1e-12);
  EXPECT_TRUE(x.v.isApprox(Eigen::Vector3d(0.0, 1.0, 0.0), 1e-9));
  EXPECT_TRUE((x.R * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-9));
}

TEST(GapTurn, HalfTurnToTheRightEndsBesideTheStart) {
  const LidarUpdater::CoastedGap gap{Eigen::Vector3d::Zero(), Eigen::Vector3d(2.0, 0.0, 0.0)};
  const NavState x = LidarUpdater::turned(coasted_prior(), gap, -M_PI, kUp);
  // A U-turn to the right along an arc of length 2: diameter 2·(2/π), ending at (0, −4/π)
  // heading −x, and 0.5 m further along −x.
  EXPECT_NEAR(x.p.x(), -0.5, 1e-9);
  EXPECT_NEAR(x.p.y(), -4.0 / M_PI, 1e-9);
  EXPECT_TRUE(x.v.isApprox(Eigen::Vector3d(-1.0, 0.0, 0.0), 1e-9));
}

TEST(GapTurn, NoTurnOrNoGapKeepsThePosition) {
  const LidarUpdater::CoastedGap gap{Eigen::Vector3d::Zero(), Eigen::Vector3d(2.0, 0.0, 0.0)};
  EXPECT_TRUE(LidarUpdater::turned(coasted_prior(), gap, 0.0, kUp).p.isApprox(coasted_prior().p));
  // A restart's prior has no coasted gap: the turn is about the prior's own position.
  const NavState x = LidarUpdater::turned(coasted_prior(), std::nullopt, M_PI / 2.0, kUp);
  EXPECT_TRUE(x.p.isApprox(coasted_prior().p));
  EXPECT_TRUE(x.v.isApprox(Eigen::Vector3d(0.0, 1.0, 0.0), 1e-9));
}

}  // namespace
}  // namespace fuse

// SessionLocalization's helpers: an initial pose given for "the IMU now" becomes the pose of the
// session frame's origin that the search looks around.
#include "fuse/estimation/session_localization.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace fuse {
namespace {

Eigen::Isometry3d pose(double x, double y, double z, double yaw, double pitch = 0.0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

TEST(SessionLocalization, APoseForTheImuNowBecomesTheSessionFramesOrigin) {
  // The session frame S placed in the map M by T_M_S (heading 1.2 rad, moved); the IMU is
  // somewhere in S, pitched a little (a heading is read about z whatever the tilt).
  const Eigen::Isometry3d T_M_S = pose(40.0, -7.0, 0.3, 1.2);
  const Eigen::Isometry3d T_S_imu = pose(3.0, 4.0, 0.2, 0.5, 0.05);
  const Eigen::Isometry3d T_M_imu = T_M_S * T_S_imu;
  InitialPose now;
  now.position = T_M_imu.translation();
  now.yaw = 1.7;  // 1.2 + 0.5: the IMU's heading in the map
  now.std_xy = 0.8;
  now.std_yaw = 0.1;
  const InitialPose start = at_session_start(now, T_S_imu);
  EXPECT_NEAR(start.yaw, 1.2, 1e-9);
  // The origin of S, up to the vertical: the search takes z from its own window.
  EXPECT_NEAR(start.position.x(), 40.0, 1e-9);
  EXPECT_NEAR(start.position.y(), -7.0, 1e-9);
  EXPECT_NEAR(start.position.z(), 0.3, 1e-9);
  EXPECT_EQ(start.std_xy, 0.8);
  EXPECT_EQ(start.std_yaw, 0.1);
}

TEST(SessionLocalization, ATrackThatIsNotLostIsNotLostFor) {
  TrackingConfig c;
  TrackingMonitor m(c);
  EXPECT_EQ(lost_for(m), 0.0);
  ScanReport good;
  good.t = 1.0;
  good.updated = true;
  good.converged = true;
  good.match_fit = 0.95;
  good.constraints = 1000;
  m.on_scan(good);
  EXPECT_EQ(lost_for(m), 0.0);
}

}  // namespace
}  // namespace fuse

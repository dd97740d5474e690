// Deskew (deskew.hpp): with a history of known motion (constant world velocity and yaw rate) and
// points measured at known times on known world geometry, the deskewed points must equal the
// points as seen from the LiDAR pose at the scan end:
//   p_L(t_e) = T_IL⁻¹ · T_WI(t_e)⁻¹ · T_WI(t_i) · T_IL · p_L(t_i).
#include "fuse/estimation/deskew.hpp"

#include <gtest/gtest.h>

#include "test_helpers.hpp"

namespace fuse {
namespace {

constexpr double kImuDt = 0.005;
constexpr double kT0 = 50.0;
constexpr double kScanStart = kT0 + 0.5023;  // not on an IMU sample
constexpr double kScanLength = 0.1;
constexpr double kYawRate = 0.8;  // rad/s
const Eigen::Vector3d kVelocity(1.5, -0.5, 0.1);
constexpr double kDeskewTol = 1e-3;  // m (float points at ≤ 20 m: ~1e-5 m round-off)

/// The true IMU pose T_WI(t): p = p0 + v·(t − T0), R = R0·Exp(ω_z (t − T0) ẑ).
Eigen::Isometry3d true_pose(double t, double yaw_rate = kYawRate) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3::Exp(Eigen::Vector3d(0, 0, 0.3)) * so3::Exp(Eigen::Vector3d(0, 0, yaw_rate * (t - kT0)));
  T.translation() = Eigen::Vector3d(2, 1, 0.5) + kVelocity * (t - kT0);
  return T;
}

Eigen::Isometry3d extrinsic() {
  Eigen::Isometry3d T_IL = Eigen::Isometry3d::Identity();
  T_IL.linear() = so3::Exp(Eigen::Vector3d(0.02, 0.03, 1.2));
  T_IL.translation() = Eigen::Vector3d(0.1, -0.05, 0.2);
  return T_IL;
}

/// History fed with the exact IMU of the motion: gyro = ω_z ẑ (the rotation R0 is fixed, so the body
/// rate is about the body z axis), accel = Rᵀ(a_W − g) = Rᵀ(−g) since the world velocity is constant
/// (yaw only, so the trapezoidal average of the specific force is exact too).
StateHistory make_history(double yaw_rate = kYawRate) {
  StateHistory h(StateHistoryConfig{}, ImuNoiseConfig{});
  NavState x0;
  const Eigen::Isometry3d T0 = true_pose(kT0, yaw_rate);
  x0.R = T0.linear();
  x0.p = T0.translation();
  x0.v = kVelocity;
  auto imu = [&](double t) {
    ImuSample s;
    s.t = t;
    s.gyro = Eigen::Vector3d(0, 0, yaw_rate);
    s.accel = true_pose(t, yaw_rate).linear().transpose() * (-x0.g);
    return s;
  };
  h.reset(kT0, x0, StateCovariance::Identity() * 1e-6, imu(kT0));
  for (int k = 1; k * kImuDt <= 0.7; ++k) h.add_imu(imu(kT0 + k * kImuDt));
  return h;
}

struct Scan {
  LidarScan scan;
  std::vector<Eigen::Vector3d> truth_at_end;  ///< each point in the LiDAR frame at the scan end
};

/// World points on the walls of a 20 m × 16 m room, each measured at its own time.
Scan make_scan(double yaw_rate = kYawRate) {
  Scan s;
  s.scan.t_start = kScanStart;
  s.scan.t_end = kScanStart + kScanLength;
  const Eigen::Isometry3d T_IL = extrinsic();
  const Eigen::Isometry3d T_WL_end = true_pose(s.scan.t_end, yaw_rate) * T_IL;
  std::mt19937 rng(30);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  constexpr int kPoints = 2000;
  for (int i = 0; i < kPoints; ++i) {
    const double t_rel = kScanLength * i / (kPoints - 1);
    Eigen::Vector3d p_W(10.0 * u(rng), 8.0 * u(rng), 1.5 * u(rng));
    if (i % 2 == 0) p_W.x() = p_W.x() > 0 ? 10.0 : -10.0; else p_W.y() = p_W.y() > 0 ? 8.0 : -8.0;
    const Eigen::Vector3d p_L = (true_pose(kScanStart + t_rel, yaw_rate) * T_IL).inverse() * p_W;
    LidarPoint lp;
    lp.x = static_cast<float>(p_L.x());
    lp.y = static_cast<float>(p_L.y());
    lp.z = static_cast<float>(p_L.z());
    lp.t_rel = static_cast<float>(t_rel);
    s.scan.points.push_back(lp);
    s.truth_at_end.push_back(T_WL_end.inverse() * p_W);
  }
  return s;
}

/// Indices of every point of the scan.
std::vector<std::uint32_t> all_points(const LidarScan& scan) {
  std::vector<std::uint32_t> all(scan.points.size());
  for (std::uint32_t i = 0; i < all.size(); ++i) all[i] = i;
  return all;
}

double max_error(const std::vector<Eigen::Vector3f>& points, const std::vector<Eigen::Vector3d>& truth) {
  double e = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) e = std::max(e, (points[i].cast<double>() - truth[i]).norm());
  return e;
}

TEST(Deskew, RecoversPointsAtScanEnd) {
  const StateHistory h = make_history();
  const Scan s = make_scan();
  Deskewer deskewer;
  ASSERT_TRUE(deskewer.prepare(h, s.scan.t_start, s.scan.t_end));
  const std::vector<std::uint32_t> all = all_points(s.scan);
  std::vector<Eigen::Vector3f> out;
  deskewer.apply(s.scan, all, extrinsic(), out);
  ASSERT_EQ(out.size(), all.size());
  EXPECT_LT(max_error(out, s.truth_at_end), kDeskewTol);

  // A subset in shuffled time order gives the same points (knot search restarts).
  std::vector<std::uint32_t> subset{1500, 3, 999, 0, 1999, 700};
  deskewer.apply(s.scan, subset, extrinsic(), out);
  for (std::size_t i = 0; i < subset.size(); ++i) {
    EXPECT_LT((out[i].cast<double>() - s.truth_at_end[subset[i]]).norm(), kDeskewTol) << "point " << subset[i];
  }
}

// Turning at 25 rad/s, the IMU samples are 0.125 rad apart: the rotation between them is no longer
// small (Rodrigues' coefficients in closed form rather than by their series), and is still exact.
TEST(Deskew, RecoversPointsWhileTurningFast) {
  constexpr double kFastYawRate = 25.0;  // rad/s
  const StateHistory h = make_history(kFastYawRate);
  const Scan s = make_scan(kFastYawRate);
  Deskewer deskewer;
  ASSERT_TRUE(deskewer.prepare(h, s.scan.t_start, s.scan.t_end));
  std::vector<Eigen::Vector3f> out;
  deskewer.apply(s.scan, all_points(s.scan), extrinsic(), out);
  EXPECT_LT(max_error(out, s.truth_at_end), kDeskewTol);
}

// Each point's ray starts where the LiDAR was when it measured the point: its origin, in the
// scan-end LiDAR frame, is the true LiDAR position at t_i there; the deskewed point lies on the
// ray from it in the measured direction at the measured range.
TEST(Deskew, GivesWhereEachRayStarted) {
  const StateHistory h = make_history();
  const Scan s = make_scan();
  Deskewer deskewer;
  ASSERT_TRUE(deskewer.prepare(h, s.scan.t_start, s.scan.t_end));
  const std::vector<std::uint32_t> all = all_points(s.scan);
  std::vector<Eigen::Vector3f> out, origins;
  deskewer.apply(s.scan, all, extrinsic(), out, &origins);
  ASSERT_EQ(origins.size(), all.size());
  const Eigen::Isometry3d T_WL_end = true_pose(s.scan.t_end) * extrinsic();
  double worst = 0.0, worst_range = 0.0;
  for (std::size_t i = 0; i < all.size(); ++i) {
    const LidarPoint& p = s.scan.points[i];
    const Eigen::Vector3d truth = T_WL_end.inverse() * (true_pose(s.scan.t_start + p.t_rel) * extrinsic()).translation();
    worst = std::max(worst, (origins[i].cast<double>() - truth).norm());
    const double range = Eigen::Vector3d(p.x, p.y, p.z).norm();
    worst_range = std::max(worst_range, std::abs((out[i] - origins[i]).cast<double>().norm() - range));
  }
  EXPECT_LT(worst, kDeskewTol);
  EXPECT_LT(worst_range, kDeskewTol);
  // The first point's ray started 0.1 s of motion (0.16 m) away from the scan end's origin.
  EXPECT_GT(origins.front().cast<double>().norm(), 0.1);
}

// Without deskew (the points as measured) the same comparison fails by far: the check can fail.
TEST(Deskew, RawPointsDoNotMatch) {
  const Scan s = make_scan();
  std::vector<Eigen::Vector3f> raw;
  for (const LidarPoint& p : s.scan.points) raw.emplace_back(p.x, p.y, p.z);
  EXPECT_GT(max_error(raw, s.truth_at_end), 100 * kDeskewTol);
}

TEST(Deskew, RefusesScanOutsideHistory) {
  const StateHistory h = make_history();
  Deskewer deskewer;
  EXPECT_FALSE(deskewer.prepare(h, kT0 - 0.2, kT0 + 0.1));  // starts before the history
  EXPECT_FALSE(deskewer.prepare(h, kT0 + 0.65, kT0 + 0.75));  // ends after the newest IMU sample
}

}  // namespace
}  // namespace fuse

// ExcitationMonitor (excitation_monitor.hpp) on motions whose body rates are known: a vehicle
// turning about its vertical axis does not excite the extrinsic, a handheld sensor swaying about
// every axis does; the window must be half full first; time going back starts over.
#include "fuse/estimation/excitation_monitor.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "fuse/core/so3.hpp"

#include "../core/config_checks.hpp"

namespace fuse {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kScanDt = 0.1;

/// Feeds scan-end attitudes for `seconds` from t0: R(t) = Exp(rate(t)·dt) accumulated in the body frame.
template <class Rate>
double feed(ExcitationMonitor& m, double t0, double seconds, const Rate& rate) {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  double t = t0;
  for (int k = 0; t < t0 + seconds; ++k) {
    m.add(t, R);
    R = R * so3::Exp(rate(t) * kScanDt);
    t += kScanDt;
  }
  return t;
}

TEST(ExcitationMonitor, AVehicleTurningOnlyAboutItsVerticalAxisDoesNotExciteIt) {
  ExcitationMonitor m(ExcitationConfig{});
  // 30 deg/s of yaw that changes sign, with 0.5 deg/s of suspension roll and pitch.
  feed(m, 0.0, 10.0, [](double t) {
    return Eigen::Vector3d(0.5 * kDeg * std::sin(7.0 * t), 0.5 * kDeg * std::cos(5.0 * t), 30.0 * kDeg * std::sin(0.5 * t));
  });
  EXPECT_NEAR(m.weakest_rate() / kDeg, 0.35, 0.1);  // RMS of a 0.5 deg/s sine
  EXPECT_FALSE(m.excited());
  // It turns about one axis, the vertical: the tilt against it is seen (one_axis: tilt).
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  ASSERT_TRUE(m.turns_about(axis));
  EXPECT_NEAR(std::abs(axis.z()), 1.0, 1e-3);
}

TEST(ExcitationMonitor, AVehicleDrivingStraightTurnsAboutNoAxis) {
  ExcitationMonitor m(ExcitationConfig{});
  feed(m, 0.0, 10.0, [](double t) {
    return Eigen::Vector3d(0.5 * kDeg * std::sin(7.0 * t), 0.5 * kDeg * std::cos(5.0 * t), 1.0 * kDeg * std::sin(0.5 * t));
  });
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  EXPECT_FALSE(m.excited());
  EXPECT_FALSE(m.turns_about(axis));
}

TEST(ExcitationMonitor, ASensorSwayingAboutEveryAxisExcitesIt) {
  ExcitationMonitor m(ExcitationConfig{});
  feed(m, 0.0, 10.0, [](double t) {
    return Eigen::Vector3d(10.0 * kDeg * std::sin(3.0 * t), 8.0 * kDeg * std::sin(2.3 * t + 1.0), 12.0 * kDeg * std::sin(1.1 * t));
  });
  EXPECT_GT(m.weakest_rate() / kDeg, 3.0);
  EXPECT_TRUE(m.excited());
}

TEST(ExcitationMonitor, TheWindowMustBeHalfFullAndTimeGoingBackStartsOver) {
  ExcitationConfig cfg;
  cfg.window_s = 4.0;
  ExcitationMonitor m(cfg);
  const auto sway = [](double t) {
    return Eigen::Vector3d(10.0 * kDeg * std::sin(3.0 * t), 10.0 * kDeg * std::cos(3.0 * t), 10.0 * kDeg * std::sin(2.0 * t));
  };
  feed(m, 0.0, 1.5, sway);
  Eigen::Vector3d axis;
  EXPECT_FALSE(m.excited());  // 1.4 s of rates: less than half of 4 s
  EXPECT_FALSE(m.turns_about(axis));
  const double t = feed(m, 1.5, 1.5, sway);
  EXPECT_TRUE(m.excited());
  feed(m, t - 10.0, 0.5, sway);  // an older time: the window restarts
  EXPECT_FALSE(m.excited());
}

TEST(ExcitationMonitor, BadValuesAreRefusedNamingTheKey) {
  expect_refused_naming_the_key<ExcitationConfig>(
      {"window_s: 0\n", "window_s: 1000\n", "min_rate_deg_s: -1\n", "min_rate_deg_s: .nan\n", "one_axis: free\n"});
}

}  // namespace
}  // namespace fuse

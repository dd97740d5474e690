// Static initialisation (static_initializer.hpp) from synthetic still data: the mean gyro is the
// gyro bias and R_WI·ā is along +z (roll and pitch); a moving window is refused, and a tracker
// that only sees motion says so on its counters.
#include "fuse/estimation/static_initializer.hpp"
#include "fuse/estimation/state_tracker.hpp"

#include <gtest/gtest.h>

#include <optional>

#include "test_helpers.hpp"

namespace fuse {
namespace {

constexpr double kRate = 200.0;
constexpr double kGravity = 9.81;
constexpr double kGyroNoise = 2e-3;   // rad/s per sample
constexpr double kAccelNoise = 2e-2;  // m/s² per sample

/// Feeds still samples (tilted body, biased gyro) until the initializer answers or max_s passes.
std::optional<NavState> run_still(StaticInitializer& init, const Eigen::Matrix3d& R_true, const Eigen::Vector3d& bg,
                                  double max_s, std::mt19937& rng, double wobble = 0.0) {
  const Eigen::Vector3d f = R_true.transpose() * Eigen::Vector3d(0, 0, kGravity);  // specific force at rest
  for (int k = 0; k < static_cast<int>(max_s * kRate); ++k) {
    ImuSample s;
    s.t = 10.0 + k / kRate;
    s.gyro = bg + test::random_vector(rng, kGyroNoise) + Eigen::Vector3d(wobble * std::sin(6.0 * s.t), 0, 0);
    s.accel = f + test::random_vector(rng, kAccelNoise);
    if (auto x = init.add(s, kGravity)) return x;
  }
  return std::nullopt;
}

TEST(StaticInitializer, AlignsGravityAndEstimatesGyroBias) {
  std::mt19937 rng(60);
  const Eigen::Matrix3d R_true = so3::Exp(Eigen::Vector3d(0.1, -0.2, 0.0));  // roll, pitch; yaw unobservable
  const Eigen::Vector3d bg(0.01, -0.005, 0.02);
  StaticInitializer init(StaticInitConfig{});
  const auto x = run_still(init, R_true, bg, 3.0, rng);
  ASSERT_TRUE(x.has_value());
  // The mean of ~200 samples: standard error kGyroNoise/√200 ≈ 1.4e-4 rad/s per axis.
  EXPECT_LT((x->bg - bg).norm(), 6e-4);
  EXPECT_EQ(x->g, Eigen::Vector3d(0, 0, -kGravity));
  // Gravity direction in the body frame (roll and pitch): R_estᵀẑ = R_trueᵀẑ within the noise (~1e-4 rad).
  const Eigen::Vector3d up_true = R_true.transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_est = x->R.transpose() * Eigen::Vector3d::UnitZ();
  EXPECT_LT(std::acos(std::min(1.0, up_true.dot(up_est))), 1e-3);
  EXPECT_EQ(x->v, Eigen::Vector3d::Zero());
  EXPECT_EQ(init.restarts(), 0u);
  // The window closes with the sample at 11.0 s (1 s after the first): the one before it, 10.995 s.
  EXPECT_NEAR(init.rest_since(), 11.0 - 1.0 / kRate, 1e-9);
}

// The sensor is swinging (gyro std well above max_gyro_std): no initial state, the window restarts.
TEST(StaticInitializer, RefusesMovingWindow) {
  std::mt19937 rng(61);
  StaticInitializer init(StaticInitConfig{});
  const auto x = run_still(init, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero(), 5.0, rng, 0.5);
  EXPECT_FALSE(x.has_value());
  EXPECT_GT(init.restarts(), 0u);
}

// A tracker whose IMU starts in motion (a fuse-state that joined a moving replay) cannot
// initialise; it counts every refused window, so that health shows why, and starts once at rest.
TEST(StaticInitializer, TrackerCountsWindowsRefusedForMotion) {
  std::mt19937 rng(62);
  StateTracker tracker{EstimatorConfig{}};
  auto feed = [&](double t0, double seconds, double wobble) {
    for (int k = 0; k < static_cast<int>(seconds * kRate); ++k) {
      ImuSample s;
      s.t = t0 + k / kRate;
      s.gyro = test::random_vector(rng, kGyroNoise) + Eigen::Vector3d(wobble * std::sin(6.0 * s.t), 0, 0);
      s.accel = Eigen::Vector3d(0, 0, kGravity) + test::random_vector(rng, kAccelNoise);
      tracker.ingest(s);
    }
  };
  feed(10.0, 5.0, 0.5);
  EXPECT_FALSE(tracker.initialised());
  EXPECT_GE(tracker.counters().get("init_not_at_rest"), 5u);
  const auto refused = tracker.counters().get("init_not_at_rest");
  feed(15.0, 2.0, 0.0);
  EXPECT_TRUE(tracker.initialised());
  EXPECT_LE(tracker.counters().get("init_not_at_rest"), refused + 2) << "still windows counted as motion";
}

}  // namespace
}  // namespace fuse

// The urban scenario and its vehicle model: a planar closed loop of 1-2 km driven at 5-20 m/s
// (slow in the corners, fast on the straights), the scheduled time law, suspension pitch and roll
// that follow the acceleration, and the engine and road vibration of the IMU (vehicles only).
#include <gtest/gtest.h>

#include <cmath>
#include <complex>

#include "fuse/sim/imu_model.hpp"
#include "fuse/sim/scenario.hpp"
#include "fuse/sim/time_law.hpp"

using namespace fuse::sim;

namespace {
constexpr double kRadToDeg = 180.0 / M_PI;
double pitch_of(const Eigen::Matrix3d& R) { return -std::asin(R(2, 0)); }  // R = Rz Ry Rx
double roll_of(const Eigen::Matrix3d& R) { return std::atan2(R(2, 1), R(2, 2)); }
// Forward and leftward acceleration in the heading frame.
Eigen::Vector2d heading_accel(const TrajectoryState& x) {
  const Eigen::Vector2d f = x.R.col(0).head<2>().normalized(), l(-f.y(), f.x());
  return {x.a.head<2>().dot(f), x.a.head<2>().dot(l)};
}
}  // namespace

TEST(SimUrban, PlanarClosedLoopBetweenFiveAndTwentyMetresPerSecond) {
  for (std::uint64_t seed : {1u, 2u}) {
    const Scenario s = make_scenario("urban", seed, seed, kStartTime, 1, 0.0, false);
    const Trajectory& tr = *s.trajectory;
    EXPECT_GT(tr.path().arc_length(), 1000.0);
    EXPECT_LT(tr.path().arc_length(), 2000.0);
    const double duration = tr.t_end() - tr.t_begin();
    EXPECT_LT(duration, 180.0);
    EXPECT_GT(s.world.boxes().size(), 500u);
    EXPECT_TRUE(s.vehicle_vibration);
    // Closed: it stops where it started, heading the same way, at rest.
    const TrajectoryState a = tr.state(tr.t_begin()), b = tr.state(tr.t_end());
    EXPECT_LT((a.p - b.p).norm(), 1e-6);
    EXPECT_LT(Eigen::AngleAxisd(a.R.transpose() * b.R).angle(), 1e-9);
    EXPECT_EQ(b.v.norm(), 0.0);
    EXPECT_EQ(b.omega_body.norm(), 0.0);
    // Planar at the roof height; speeds within 5-20 m/s between the first and last time at 5 m/s.
    double first = -1.0, last = -1.0, top = 0.0;
    std::vector<std::pair<double, double>> speeds;
    for (double t = tr.t_begin(); t <= tr.t_end(); t += 0.01) {
      const TrajectoryState x = tr.state(t);
      ASSERT_NEAR(x.p.z(), 1.9, 1e-12);
      ASSERT_EQ(x.v.z(), 0.0);
      const double v = x.v.norm();
      speeds.emplace_back(t, v);
      if (v >= 5.0) {
        if (first < 0.0) first = t;
        last = t;
      }
      top = std::max(top, v);
    }
    double low = 1e9;
    for (const auto& [t, v] : speeds)
      if (t >= first && t <= last) low = std::min(low, v);
    EXPECT_GE(low, 5.0) << "seed " << seed;
    EXPECT_LE(top, 20.0);
    EXPECT_GT(top, 14.0) << "fast on the long straights";
    EXPECT_LT(low, 8.0) << "slow in the corners";
    EXPECT_LT(last - first, duration - 5.0) << "rest and ramps at both ends";
  }
}

TEST(SimUrban, SuspensionPitchAndRollFollowTheAcceleration) {
  const Scenario s = make_scenario("urban", 3, 3, kStartTime, 1, 0.0, false);
  const Trajectory& tr = *s.trajectory;
  double max_pitch = 0.0, max_roll = 0.0, braking_pitch = 0.0, accelerating_pitch = 0.0, turning_roll = 0.0;
  int braking = 0, accelerating = 0, turning = 0;
  for (double t = tr.t_begin(); t <= tr.t_end(); t += 0.02) {
    const TrajectoryState x = tr.state(t);
    const double pitch = pitch_of(x.R) * kRadToDeg, roll = roll_of(x.R) * kRadToDeg;
    max_pitch = std::max(max_pitch, std::abs(pitch));
    max_roll = std::max(max_roll, std::abs(roll));
    const Eigen::Vector2d a = heading_accel(x);
    if (a.x() < -1.5) {
      braking_pitch += pitch;
      ++braking;
    }
    if (a.x() > 1.5) {
      accelerating_pitch += pitch;
      ++accelerating;
    }
    if (std::abs(a.y()) > 1.5) {
      turning_roll += roll * (a.y() > 0 ? 1.0 : -1.0);
      ++turning;
    }
  }
  EXPECT_GT(max_pitch, 0.3);  // a few tenths of a degree per m/s^2
  EXPECT_LT(max_pitch, 3.0);
  EXPECT_GT(max_roll, 0.5);
  EXPECT_LT(max_roll, 3.0);
  ASSERT_GT(braking, 50);
  ASSERT_GT(accelerating, 50);
  ASSERT_GT(turning, 50);
  EXPECT_GT(braking_pitch / braking, 0.2) << "nose down when braking";
  EXPECT_LT(accelerating_pitch / accelerating, -0.2) << "nose up when accelerating";
  EXPECT_GT(turning_roll / turning, 0.3) << "rolled out of the turn";
}

TEST(SimUrban, WalkStartedAlongTheLoopKeepsTheCornersSlow) {
  const Scenario full = make_scenario("urban", 4, 4, kStartTime, 1, 0.0, false);
  const Scenario later = make_scenario("urban", 4, 4, kStartTime, 1, 300.0, false);
  const TimeLawConfig& law = later.trajectory->time_law().config();
  ASSERT_FALSE(law.limits.empty());
  EXPECT_EQ(later.trajectory->state(later.trajectory->t_begin()).v.norm(), 0.0);
  EXPECT_LT((later.trajectory->state(later.trajectory->t_begin()).p - full.trajectory->path().at(300.0).c).norm(),
            1e-9);
  double top = 0.0;
  for (double t = later.trajectory->t_begin(); t <= later.trajectory->t_end(); t += 0.05)
    top = std::max(top, later.trajectory->state(t).v.norm());
  EXPECT_LE(top, 20.0);
}

TEST(SimTimeLaw, ScheduledSpeedsHonourTheLimitsAndTheAcceleration) {
  TimeLawConfig c;
  c.rate = 15.0;
  c.max_accel = 2.0;
  c.limits = {{300.0, 340.0, 6.0}, {200.0, 220.0, 8.0}, {330.0, 360.0, 5.0}, {620.0, 640.0, 7.0}};
  const double u_end = 700.0;
  const TimeLaw law(c, u_end);
  EXPECT_EQ(law.at(0.0).u, 0.0);
  EXPECT_EQ(law.at(c.rest_start_s).u1, 0.0);
  EXPECT_NEAR(law.at(law.duration()).u, u_end, 1e-9);
  EXPECT_EQ(law.at(law.duration() - 0.5 * c.rest_end_s).u1, 0.0);
  double top = 0.0, max_accel = 0.0;
  for (double t = 0.0; t <= law.duration(); t += 0.01) {
    const TimeLawSample s = law.at(t);
    top = std::max(top, s.u1);
    max_accel = std::max(max_accel, std::abs(s.u2));
    // Within every limited stretch (the overlapping two merge at the lower rate), at most its rate.
    const double limit = s.u >= 200.0 && s.u <= 220.0   ? 8.0
                         : s.u >= 300.0 && s.u <= 360.0 ? 5.0
                         : s.u >= 620.0 && s.u <= 640.0 ? 7.0
                                                        : c.rate;
    ASSERT_LE(s.u1, limit + 1e-9) << "u " << s.u;
    ASSERT_GE(s.u1, 0.0);
  }
  EXPECT_LE(max_accel, c.max_accel + 1e-9);
  EXPECT_GT(max_accel, 0.95 * c.max_accel);
  EXPECT_GT(top, 12.0);  // the long stretch from 360 to 620 m reaches well above the limits
  EXPECT_LE(top, c.rate);
  for (double t = 0.013; t < law.duration(); t += 0.37) {  // derivatives vs central differences
    const double h = 1e-5;
    const TimeLawSample s = law.at(t), a = law.at(t - h), b = law.at(t + h);
    EXPECT_NEAR(s.u1, (b.u - a.u) / (2 * h), 1e-6) << t;
    EXPECT_NEAR(s.u2, (b.u1 - a.u1) / (2 * h), 1e-5) << t;
    EXPECT_NEAR(s.u3, (b.u2 - a.u2) / (2 * h), 1e-3) << t;
  }
  // Continuity across the phases.
  for (const TimeLaw::Phase& p : law.phases()) {
    const TimeLawSample a = law.at(p.t_begin - 1e-9), b = law.at(p.t_begin + 1e-9);
    EXPECT_NEAR(a.u, b.u, 1e-6);
    EXPECT_NEAR(a.u1, b.u1, 1e-6);
  }
  TimeLawConfig bad = c;
  bad.limits = {{10.0, 5.0, 3.0}};
  EXPECT_THROW(TimeLaw(bad, u_end), std::invalid_argument);
  bad.limits = {{10.0, 20.0, 0.0}};
  EXPECT_THROW(TimeLaw(bad, u_end), std::invalid_argument);
  bad.limits = {{10.0, 20.0, 3.0}};
  bad.max_accel = 0.0;
  EXPECT_THROW(TimeLaw(bad, u_end), std::invalid_argument);
}

TEST(SimTimeLaw, StopsComeToRestAtTheirPlaceForTheirDwell) {
  TimeLawConfig c;
  c.rate = 12.0;
  c.max_accel = 2.0;
  c.limits = {{300.0, 340.0, 6.0}};
  c.stops = {{150.0, 4.0}, {450.0, 2.5}};
  const double u_end = 700.0;
  const TimeLaw law(c, u_end);
  EXPECT_NEAR(law.at(law.duration()).u, u_end, 1e-9);
  // Each stop: the rate reaches 0 at its place and stays 0 for exactly its dwell.
  for (const Stop& stop : c.stops) {
    double first = -1.0, last = -1.0;
    for (double t = 0.0; t <= law.duration(); t += 0.001) {
      const TimeLawSample s = law.at(t);
      if (std::abs(s.u - stop.u) < 1e-9 && s.u1 == 0.0) {
        if (first < 0.0) first = t;
        last = t;
      }
      ASSERT_GE(s.u1, 0.0);
      ASSERT_LE(std::abs(s.u2), c.max_accel + 1e-9);
    }
    ASSERT_GE(first, 0.0) << "never at rest at u = " << stop.u;
    EXPECT_NEAR(last - first, stop.dwell_s, 2e-3) << "u = " << stop.u;
  }
  // Smooth through the stops: derivatives against central differences, continuity at the phases.
  for (double t = 0.013; t < law.duration(); t += 0.37) {
    const double h = 1e-5;
    const TimeLawSample s = law.at(t), a = law.at(t - h), b = law.at(t + h);
    EXPECT_NEAR(s.u1, (b.u - a.u) / (2 * h), 1e-6) << t;
    EXPECT_NEAR(s.u2, (b.u1 - a.u1) / (2 * h), 1e-5) << t;
  }
  // The same law from 200 m on keeps the second stop, 250 m along.
  const TimeLawConfig later = c.from(200.0);
  ASSERT_EQ(later.stops.size(), 1u);
  EXPECT_NEAR(later.stops[0].u, 250.0, 1e-12);
  TimeLawConfig bad = c;
  bad.stops = {{320.0, 4.0}};  // inside the limited stretch
  EXPECT_THROW(TimeLaw(bad, u_end), std::invalid_argument);
  bad.stops = {{800.0, 4.0}};  // beyond the path
  EXPECT_THROW(TimeLaw(bad, u_end), std::invalid_argument);
  bad.stops = {{150.0, -1.0}};
  EXPECT_THROW(TimeLaw(bad, u_end), std::invalid_argument);
}

TEST(SimUrban, StopsWaitAtTheStopLineBeforeTheFirstCorners) {
  const Scenario plain = make_scenario("urban", 3, 3, kStartTime, 1, 0.0, false);
  const Scenario stopping = make_scenario("urban", 3, 3, kStartTime, 1, 0.0, false, 2);
  const Trajectory& t = *stopping.trajectory;
  EXPECT_GT(t.t_end() - plain.trajectory->t_end(), 2.0 * kStopDwellS) << "two waits and their slow-downs";
  EXPECT_NEAR(t.path().u_end(), plain.trajectory->path().u_end(), 1e-9) << "the same path";
  // Rested stretches after the start: the two stops, each kStopDwellS long.
  std::vector<double> rests;
  double since = -1.0;
  for (double time = t.t_begin() + 4.0; time <= t.t_end() - 3.0; time += 0.01) {
    const bool still = t.state(time).v.norm() < 1e-9;
    if (still && since < 0.0) since = time;
    if (!still && since >= 0.0) {
      rests.push_back(time - since);
      since = -1.0;
    }
  }
  ASSERT_EQ(rests.size(), 2u);
  for (double r : rests) EXPECT_NEAR(r, kStopDwellS, 0.02);
  EXPECT_THROW(make_scenario("corridor", 1, 1, kStartTime, 1, 0.0, true, 1), std::invalid_argument);
  EXPECT_THROW(make_scenario("urban", 1, 1, kStartTime, 1, 0.0, false, 99), std::invalid_argument);
}

namespace {
// Amplitude spectrum peak (Hz) of x sampled at `rate` between lo and hi Hz (plain DFT).
double peak_frequency(const std::vector<double>& x, double rate, double lo, double hi) {
  const std::size_t n = x.size();
  double best = 0.0, best_f = 0.0;
  for (std::size_t k = 1; k < n / 2; ++k) {
    const double f = rate * static_cast<double>(k) / static_cast<double>(n);
    if (f < lo || f > hi) continue;
    std::complex<double> sum = 0.0;
    for (std::size_t i = 0; i < n; ++i) sum += x[i] * std::polar(1.0, -2.0 * M_PI * static_cast<double>(k * i) / n);
    if (std::abs(sum) > best) {
      best = std::abs(sum);
      best_f = f;
    }
  }
  return best_f;
}
}  // namespace

// The vibration is the difference between a vehicle's IMU and the same IMU without vibration (the
// white noise and biases are the same draws): engine harmonics in 25-40 Hz, a few tenths of m/s^2
// and a few hundredths of rad/s, growing with speed; other scenarios have none.
TEST(SimVibration, EngineAndRoadVibrationOfTheVehicleImu) {
  const Scenario s = make_scenario("urban", 2, 2, kStartTime, 1, 0.0, false);
  for (const char* name : {"corridor", "stairs", "room", "campus"})
    EXPECT_FALSE(make_scenario(name, 1, 1).vehicle_vibration) << name;
  const Trajectory& tr = *s.trajectory;
  ImuNoiseConfig plain_cfg, shaken_cfg;
  shaken_cfg.vibration = vehicle_vibration(2);
  ASSERT_EQ(shaken_cfg.vibration.engine.size(), 3u);
  for (const EngineComponent& e : shaken_cfg.vibration.engine) {
    EXPECT_GE(e.idle_hz, 25.0);
    EXPECT_LE(e.idle_hz * (1.0 + shaken_cfg.vibration.engine_rise), 40.0);
  }
  ImuSimulator plain(plain_cfg, 2), shaken(shaken_cfg, 2);
  const double rate = plain_cfg.rate_hz;
  std::vector<double> az_rest, az_moving;
  double a2_rest = 0.0, a2_moving = 0.0, g2_moving = 0.0;
  int rest = 0, moving = 0;
  for (int i = 0; i < static_cast<int>((tr.t_end() - tr.t_begin()) * rate); ++i) {
    const TrajectoryState x = tr.state(tr.t_begin() + i / rate);
    const fuse::ImuSample p = plain.measure(x), q = shaken.measure(x);
    ASSERT_EQ(p.t, q.t);
    const Eigen::Vector3d da = q.accel - p.accel, dg = q.gyro - p.gyro;
    if (x.v.norm() == 0.0 && i < 2 * rate) {  // idling at the start
      a2_rest += da.squaredNorm();
      ++rest;
      az_rest.push_back(da.z());
    } else if (x.v.norm() > 15.0) {
      a2_moving += da.squaredNorm();
      g2_moving += dg.squaredNorm();
      ++moving;
      if (az_moving.size() < 400) az_moving.push_back(da.z());
    }
  }
  ASSERT_GT(rest, 300);
  ASSERT_GT(moving, 400);
  const double rms_rest = std::sqrt(a2_rest / rest), rms_moving = std::sqrt(a2_moving / moving);
  const double gyro_moving = std::sqrt(g2_moving / moving);
  EXPECT_GT(rms_rest, 0.05);  // the engine idles
  EXPECT_GT(rms_moving, 0.2);
  EXPECT_LT(rms_moving, 0.6);
  EXPECT_GT(rms_moving, rms_rest * 1.3);  // engine load and road noise grow with speed
  EXPECT_GT(gyro_moving, 0.008);
  EXPECT_LT(gyro_moving, 0.04);
  const double f_rest = peak_frequency(az_rest, rate, 5.0, 95.0), f_moving = peak_frequency(az_moving, rate, 5.0, 95.0);
  EXPECT_GE(f_rest, 24.5);
  EXPECT_LE(f_rest, 30.0);
  EXPECT_GE(f_moving, 25.0);
  EXPECT_LE(f_moving, 40.5);
  EXPECT_GT(f_moving, f_rest) << "the engine turns faster at speed";
  // Same seed, same vibration; the vibration comes from its own streams.
  const VibrationConfig again = vehicle_vibration(2), other = vehicle_vibration(3);
  EXPECT_EQ(again.engine[0].idle_hz, shaken_cfg.vibration.engine[0].idle_hz);
  EXPECT_NE(other.engine[0].idle_hz, shaken_cfg.vibration.engine[0].idle_hz);
}

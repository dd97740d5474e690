// Real-IMU propagation check on EuRoC V1_02_medium (ADIS16448 at 200 Hz, ground truth from the
// dataset's state estimate: position, attitude, velocity and IMU biases of the body = IMU frame).
// Every second: start from the ground-truth state, propagate one second of real IMU with
// fuse::propagate, compare position and attitude with the ground truth at the end. The bound and
// its derivation: docs/evaluation.md, "Real IMU propagation check (EuRoC V1_02_medium)".
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "fuse/estimation/imu_propagation.hpp"

namespace fuse {
namespace {

const std::filesystem::path kSequence = std::filesystem::path(FUSE_SHARED_DATA) / "euroc" / "V1_02_medium";

// EuRoC ADIS16448 noise model (imu0_sensor.yaml of V1_01_easy, the same sensor).
constexpr double kGyroNoise = 1.6968e-4;     // rad/s/√Hz
constexpr double kAccelNoise = 2.0e-3;       // m/s²/√Hz
constexpr double kGyroBiasWalk = 1.9393e-5;  // rad/s²/√Hz
constexpr double kAccelBiasWalk = 3.0e-3;    // m/s³/√Hz
constexpr double kGravity = 9.81;            // m/s², world z up (EuRoC Vicon frame)
constexpr double kWindow = 1.0;              // s, propagation horizon
constexpr std::int64_t kNsPerS = 1000000000;
constexpr std::int64_t kMatchTolNs = 1000000;  // 1 ms: ground-truth rows sit on IMU sample times

// The bound (docs/evaluation.md): the 99.7 % radius of a 3-D Gaussian (3.77σ, χ with 3 degrees of
// freedom) of the per-axis 1σ budget after T = 1 s.
constexpr double kChi3Quantile = 3.77;
// Position, per axis: IMU noise (propagated covariance, 1.4 mm), reference velocity error
// σ_v·T (σ_v = 0.8 cm/s) and acceleration-level reference error ½·σ_a·T² (σ_a = 5 cm/s²).
constexpr double kSigmaPositionImu = 0.0014, kSigmaVelocityGt = 0.008, kSigmaAccelGt = 0.05;
const double kPositionBound =
    kChi3Quantile * std::sqrt(std::pow(kSigmaPositionImu, 2) + std::pow(kSigmaVelocityGt * kWindow, 2) +
                              std::pow(0.5 * kSigmaAccelGt * kWindow * kWindow, 2));  // ≈ 0.099 m
// Attitude, per axis: gyro white noise σ_g·√T, reference attitude error at both ends √2·σ_θ
// (σ_θ = 1 mrad) and reference gyro bias error σ_bg·T (σ_bg = 0.5 mrad/s).
constexpr double kSigmaAttitudeGt = 1.0e-3, kSigmaGyroBiasGt = 0.5e-3;
const double kAttitudeBound =
    kChi3Quantile * std::sqrt(kGyroNoise * kGyroNoise * kWindow + 2.0 * kSigmaAttitudeGt * kSigmaAttitudeGt +
                              std::pow(kSigmaGyroBiasGt * kWindow, 2));  // ≈ 5.7 mrad

struct ImuRow {
  std::int64_t ns;
  Eigen::Vector3d gyro, accel;
};

struct GtRow {
  std::int64_t ns;
  Eigen::Vector3d p;
  Eigen::Quaterniond q;  // R_WI (body = IMU frame)
  Eigen::Vector3d v, bg, ba;
};

/// Parses the numeric columns of a EuRoC csv line (first column: ns timestamp).
bool parse_line(const std::string& line, std::int64_t& ns, std::vector<double>& values) {
  if (line.empty() || line[0] == '#') return false;
  std::stringstream ss(line);
  std::string cell;
  if (!std::getline(ss, cell, ',')) return false;
  ns = std::stoll(cell);
  values.clear();
  while (std::getline(ss, cell, ',')) values.push_back(std::stod(cell));
  return true;
}

std::vector<ImuRow> load_imu(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::vector<ImuRow> rows;
  std::string line;
  std::int64_t ns;
  std::vector<double> v;
  while (std::getline(in, line)) {
    if (parse_line(line, ns, v) && v.size() == 6) rows.push_back({ns, {v[0], v[1], v[2]}, {v[3], v[4], v[5]}});
  }
  return rows;
}

std::vector<GtRow> load_groundtruth(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::vector<GtRow> rows;
  std::string line;
  std::int64_t ns;
  std::vector<double> v;
  while (std::getline(in, line)) {
    if (!parse_line(line, ns, v) || v.size() != 16) continue;
    rows.push_back({ns, {v[0], v[1], v[2]}, Eigen::Quaterniond(v[3], v[4], v[5], v[6]).normalized(),
                    {v[7], v[8], v[9]}, {v[10], v[11], v[12]}, {v[13], v[14], v[15]}});
  }
  return rows;
}

/// Index of the IMU sample at ns (within kMatchTolNs), or -1.
long imu_index_at(const std::vector<ImuRow>& imu, std::int64_t ns) {
  const auto it = std::lower_bound(imu.begin(), imu.end(), ns - kMatchTolNs,
                                   [](const ImuRow& r, std::int64_t t) { return r.ns < t; });
  if (it == imu.end() || std::llabs(it->ns - ns) > kMatchTolNs) return -1;
  return static_cast<long>(it - imu.begin());
}

NavState state_of(const GtRow& gt) {
  NavState x;
  x.p = gt.p;
  x.R = gt.q.toRotationMatrix();
  x.v = gt.v;
  x.bg = gt.bg;
  x.ba = gt.ba;
  x.g = Eigen::Vector3d(0, 0, -kGravity);
  return x;
}

struct WindowError {
  double t;               // s since the first window
  double position;        // m, at the window end
  double attitude;        // rad, at the window end
  double position_sigma;  // m, predicted by the propagated covariance (IMU noise only)
  Eigen::Vector3d fit_velocity = Eigen::Vector3d::Zero();  // m/s: δp(τ) ≈ δv·τ + ½·δa·τ² (least squares)
  Eigen::Vector3d fit_acceleration = Eigen::Vector3d::Zero();  // m/s²
};

/// Least-squares fit of δp(τ) = δv·τ + ½·δa·τ² to the position errors along the window: the part
/// growing linearly is an initial velocity error, the quadratic part an acceleration error
/// (accelerometer bias error, or gravity projected through an attitude error: g·δθ).
void fit_error_growth(const std::vector<double>& tau, const std::vector<Eigen::Vector3d>& dp, WindowError& err) {
  Eigen::MatrixXd A(static_cast<long>(tau.size()), 2);
  Eigen::MatrixXd b(static_cast<long>(tau.size()), 3);
  for (std::size_t i = 0; i < tau.size(); ++i) {
    A.row(static_cast<long>(i)) << tau[i], 0.5 * tau[i] * tau[i];
    b.row(static_cast<long>(i)) = dp[i].transpose();
  }
  const Eigen::MatrixXd sol = A.colPivHouseholderQr().solve(b);
  err.fit_velocity = sol.row(0).transpose();
  err.fit_acceleration = sol.row(1).transpose();
}

/// Propagates from the ground truth at gt[i0] over the IMU samples up to gt[i1] (trapezoidal
/// average of consecutive samples, as StateHistory does), with the gyro bias scaled by bias_scale
/// (1 = ground truth), and records the position error at every ground-truth row on the way.
bool propagate_window(const std::vector<ImuRow>& imu, const std::vector<GtRow>& gt, std::size_t i0, std::size_t i1,
                      double bias_scale, WindowError& err) {
  const long k0 = imu_index_at(imu, gt[i0].ns), k1 = imu_index_at(imu, gt[i1].ns);
  if (k0 < 0 || k1 <= k0) return false;
  ImuNoiseConfig noise;
  noise.gyro_noise_density = kGyroNoise;
  noise.accel_noise_density = kAccelNoise;
  noise.gyro_bias_random_walk = kGyroBiasWalk;
  noise.accel_bias_random_walk = kAccelBiasWalk;
  NavState x = state_of(gt[i0]);
  x.bg *= bias_scale;
  StateCovariance P = StateCovariance::Zero();
  std::vector<double> tau;
  std::vector<Eigen::Vector3d> dp;
  std::size_t next_gt = i0 + 1;
  for (long k = k0; k < k1; ++k) {
    const ImuRow& a = imu[static_cast<std::size_t>(k)];
    const ImuRow& b = imu[static_cast<std::size_t>(k + 1)];
    propagate(x, &P, 0.5 * (a.gyro + b.gyro), 0.5 * (a.accel + b.accel), static_cast<double>(b.ns - a.ns) / kNsPerS,
              noise);
    if (next_gt <= i1 && std::llabs(gt[next_gt].ns - b.ns) <= kMatchTolNs) {
      tau.push_back(static_cast<double>(b.ns - gt[i0].ns) / kNsPerS);
      dp.push_back(x.p - gt[next_gt].p);
      ++next_gt;
    }
  }
  const GtRow& end = gt[i1];
  err.position = (x.p - end.p).norm();
  err.attitude = so3::Log(end.q.toRotationMatrix().transpose() * x.R).norm();
  err.position_sigma = std::sqrt(P.block<3, 3>(Idx::kPos, Idx::kPos).trace());
  if (tau.size() >= 3) fit_error_growth(tau, dp, err);
  return true;
}

struct Distribution {
  double median = 0, p90 = 0, max = 0;
};

Distribution distribution(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  auto at = [&](double q) { return v[static_cast<std::size_t>(std::lround(q * static_cast<double>(v.size() - 1)))]; };
  return {at(0.5), at(0.9), v.back()};
}

/// Every second: one window per ground-truth row that starts a new second (GT rows are 25 ms apart).
std::vector<WindowError> run_windows(const std::vector<ImuRow>& imu, const std::vector<GtRow>& gt, double bias_scale) {
  std::vector<WindowError> out;
  const std::int64_t window_ns = static_cast<std::int64_t>(kWindow * kNsPerS);
  std::size_t i = 0;
  while (i < gt.size()) {
    const auto end = std::lower_bound(gt.begin() + static_cast<long>(i), gt.end(), gt[i].ns + window_ns - kMatchTolNs,
                                      [](const GtRow& r, std::int64_t t) { return r.ns < t; });
    if (end == gt.end()) break;
    WindowError e{static_cast<double>(gt[i].ns - gt.front().ns) / kNsPerS, 0, 0, 0};
    const auto i_end = static_cast<std::size_t>(end - gt.begin());
    if (std::llabs(end->ns - gt[i].ns - window_ns) <= kMatchTolNs && propagate_window(imu, gt, i, i_end, bias_scale, e)) {
      out.push_back(e);
    }
    i = static_cast<std::size_t>(end - gt.begin());
  }
  return out;
}

/// Ground-truth velocity consistency: |v_gt − (p(t+h) − p(t−h))/2h| with h = 0.1 s.
std::vector<double> velocity_consistency(const std::vector<GtRow>& gt) {
  constexpr int kHalfSpan = 4;  // rows of 25 ms
  std::vector<double> out;
  for (std::size_t i = kHalfSpan; i + kHalfSpan < gt.size(); ++i) {
    const GtRow &a = gt[i - kHalfSpan], &b = gt[i + kHalfSpan];
    const Eigen::Vector3d v_fd = (b.p - a.p) / (static_cast<double>(b.ns - a.ns) / kNsPerS);
    out.push_back((v_fd - gt[i].v).norm());
  }
  return out;
}

class EurocImuCheck : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!std::filesystem::exists(kSequence / "imu0.csv") || !std::filesystem::exists(kSequence / "groundtruth.csv")) {
      GTEST_SKIP() << "EuRoC data absent: " << kSequence.string() << " (set FUSE_SHARED_DATA)";
    }
    imu_ = load_imu(kSequence / "imu0.csv");
    gt_ = load_groundtruth(kSequence / "groundtruth.csv");
    ASSERT_GT(imu_.size(), 1000u);
    ASSERT_GT(gt_.size(), 100u);
  }
  std::vector<ImuRow> imu_;
  std::vector<GtRow> gt_;
};

void print_distribution(const char* name, const Distribution& d, double scale, const char* unit) {
  std::cout << std::fixed << std::setprecision(2) << "  " << std::left << std::setw(26) << name << " median "
            << d.median * scale << "  p90 " << d.p90 * scale << "  max " << d.max * scale << " " << unit << "\n";
}

TEST_F(EurocImuCheck, OneSecondPropagationFromGroundTruth) {
  const std::vector<WindowError> errors = run_windows(imu_, gt_, 1.0);
  ASSERT_GE(errors.size(), 30u) << "expected ~38 one-second windows where IMU and ground truth overlap";
  std::vector<double> pos, att, sig, fit_v, fit_a;
  for (const auto& e : errors) {
    pos.push_back(e.position);
    att.push_back(e.attitude);
    sig.push_back(e.position_sigma);
    fit_v.push_back(e.fit_velocity.norm());
    fit_a.push_back(e.fit_acceleration.norm());
  }
  const Distribution dp = distribution(pos), da = distribution(att), ds = distribution(sig);
  const Distribution dv = distribution(velocity_consistency(gt_));
  std::cout << "EuRoC V1_02_medium, " << errors.size() << " windows of " << kWindow << " s:\n";
  print_distribution("position error", dp, 100.0, "cm");
  print_distribution("attitude error", da, 1000.0, "mrad");
  print_distribution("IMU-noise 1σ (covariance)", ds, 100.0, "cm");
  print_distribution("GT |v − dp/dt| (h=0.1 s)", dv, 100.0, "cm/s");
  print_distribution("fitted |δv| (linear part)", distribution(fit_v), 100.0, "cm/s");
  print_distribution("fitted |δa| (quadratic)", distribution(fit_a), 100.0, "cm/s²");
  for (const auto& e : errors) {
    std::cout << std::setprecision(3) << "    t=" << e.t << " pos " << e.position * 100 << " cm  att " << e.attitude * 1000
              << " mrad  δv " << e.fit_velocity.transpose() * 100 << " cm/s  δa " << e.fit_acceleration.transpose() * 100
              << " cm/s²\n";
  }
  RecordProperty("windows", static_cast<int>(errors.size()));
  RecordProperty("position_median_m", std::to_string(dp.median));
  RecordProperty("position_p90_m", std::to_string(dp.p90));
  RecordProperty("position_max_m", std::to_string(dp.max));
  RecordProperty("attitude_median_rad", std::to_string(da.median));
  RecordProperty("attitude_p90_rad", std::to_string(da.p90));
  RecordProperty("attitude_max_rad", std::to_string(da.max));
  std::cout << std::setprecision(2) << "  bound: position " << kPositionBound * 100 << " cm, attitude "
            << kAttitudeBound * 1000 << " mrad\n";
  EXPECT_LT(dp.max, kPositionBound);
  EXPECT_LT(da.max, kAttitudeBound);
}

// The check can fail: without the gyro bias the attitude error grows at |b_g| ≈ 0.08 rad/s.
TEST_F(EurocImuCheck, ZeroGyroBiasViolatesTheBound) {
  const std::vector<WindowError> errors = run_windows(imu_, gt_, 0.0);
  ASSERT_FALSE(errors.empty());
  std::vector<double> pos, att;
  for (const auto& e : errors) {
    pos.push_back(e.position);
    att.push_back(e.attitude);
  }
  const Distribution dp = distribution(pos), da = distribution(att);
  std::cout << "with b_g = 0:\n";
  print_distribution("position error", dp, 100.0, "cm");
  print_distribution("attitude error", da, 1000.0, "mrad");
  EXPECT_GT(da.median, kAttitudeBound);
  EXPECT_GT(dp.max, kPositionBound);
}

}  // namespace
}  // namespace fuse

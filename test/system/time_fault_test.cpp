// Faults in time and IMU-only faults while walking, injected into a copy of the 10 s corridor
// sequence and judged against the simulator's truth (docs/architecture.md, "Time is checked like
// any input", "IMU-only dropouts"):
//   - one IMU sample stamped 10 s ahead or behind: dropped and counted (TimeGate), no harm;
//   - the IMU silent for 0.3–1.0 s while the LiDAR runs, and 1 s of NaN gyro: the scans in the
//     gap are coasted to (StateTracker::coast_to) and re-localised;
//   - duplicate and swapped IMU samples: counted, no harm;
//   - both clocks stepping by ±100 s for the rest of the run: a clock step, re-localised;
//   - fuse-run's exit codes: 0 clean, 3 diverged (with the reason), 1 for an --out that cannot be
//     created, 2 for an empty config file.
// A handled fault stays within 2x of the clean run's ATE, or 2 cm over it (handled_bound); an
// unhandled one is off by metres: the negative controls switch the handling off by config and
// must fail that bound.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "fuse/eval/evaluate.hpp"
#include "fuse/eval/trajectory.hpp"
#include "faulty_sequence.hpp"
#include "run_command.hpp"
#include "runner.hpp"

namespace fuse {
namespace {

namespace fs = std::filesystem;
using namespace fuse::test;

const std::string kSeqdir = std::string(FUSE_TEST_DATA) + "/seqdir10";
const std::string kConfig = std::string(FUSE_CONFIG_DIR) + "/mid360.yaml";
/// A handled fault costs at most this factor of the clean run's ATE, or kAteAllowance over it
/// when that is more: re-localising after a gap settles within a centimetre or so, whatever the
/// clean run's own error (23.5 mm on this walk before the zero-velocity update at rest, 2.5 mm
/// with it). An unhandled fault is off by metres.
constexpr double kAteFactor = 2.0;
constexpr double kAteAllowance = 0.02;  // m
/// Phases of the walk (absolute times of the sequence, which starts at 1000 s and initialises
/// for about 1 s): the first sample after each is where a fault starts.
constexpr double kPhases[] = {1003.0, 1005.03, 1007.2};

/// Both clocks step by `step` s from time t on: IMU samples after t, scans starting at or after t.
void step_clocks(Lines& imu, Lines& scans, double t, double step) {
  for (std::size_t i = first_after(imu, t); i < imu.size(); ++i) imu[i] = restamp_imu(imu[i], step);
  for (std::size_t i = 1; i < scans.size(); ++i) {
    int idx = 0;
    double t0 = 0.0, t1 = 0.0;
    std::sscanf(scans[i].c_str(), "%d,%lf,%lf", &idx, &t0, &t1);
    if (t0 < t - 1e-9) continue;
    char row[96];
    std::snprintf(row, sizeof row, "%d,%.9f,%.9f", idx, t0 + step, t1 + step);
    scans[i] = row;
  }
}

struct FaultRun {
  RunSummary summary;
  double ate = 0.0;
  std::uint64_t count(const std::string& key) const {
    std::uint64_t n = 0;
    for (const auto* m : {&summary.input_rejected, &summary.estimator_counts}) {
      const auto it = m->find(key);
      if (it != m->end()) n += it->second;
    }
    return n;
  }
};

/// Runs fuse-run's pipeline on `dir`; the ATE against the truth, with the poses after a clock
/// step of `step` s at `step_at` moved back onto the truth's time.
FaultRun run_on(const fs::path& dir, const std::vector<std::string>& overrides = {}, double step_at = 0.0,
           double step = 0.0) {
  FaultRun r;
  r.summary = run_offline(load_runner_config(kConfig, overrides), dir.string(), "");
  std::vector<StampedPose> poses = r.summary.trajectory;
  if (step != 0.0) {
    for (auto& p : poses) {
      // Poses stamped in the stepped clock (nearer to step_at + step than to step_at) go back.
      if (std::abs(p.t - (step_at + step)) < std::abs(p.t - step_at)) p.t -= step;
    }
  }
  if (!poses.empty()) {
    r.ate = eval::evaluate(eval::read_tum(kSeqdir + "/groundtruth.tum"), poses, eval::EvaluationConfig{}).ate.rmse;
  }
  return r;
}

FaultRun run_fault(const std::string& name, const std::function<void(Lines&, Lines&)>& edit,
              const std::vector<std::string>& overrides = {}, double step_at = 0.0, double step = 0.0) {
  const fs::path dir = faulty_sequence(kSeqdir, name, edit);
  FaultRun r = run_on(dir, overrides, step_at, step);
  fs::remove_all(dir);
  return r;
}

/// The clean run's ATE (computed once).
double clean_ate() {
  static const double ate = run_on(kSeqdir).ate;
  return ate;
}

/// The ATE a handled fault stays within.
double handled_bound() { return std::max(kAteFactor * clean_ate(), clean_ate() + kAteAllowance); }

std::string test_name() { return ::testing::UnitTest::GetInstance()->current_test_info()->name(); }

void report(const std::string& what, const FaultRun& r) {
  std::cout << what << ": ATE " << r.ate * 1000.0 << " mm (clean " << clean_ate() * 1000.0 << " mm), tracking "
            << to_string(r.summary.tracking) << ", relocalizing " << r.summary.relocalizing_s << " s, lost "
            << r.summary.lost_s << " s" << (r.summary.diverged ? ", diverged: " + r.summary.divergence : "") << "\n";
  ::testing::Test::RecordProperty("ate_mm", std::to_string(r.ate * 1000.0));
}

class TimeFault : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kSeqdir + "/scans.csv")) GTEST_SKIP() << "fixture missing: " << kSeqdir;
    ASSERT_GT(clean_ate(), 0.0);
  }
};

// --- One IMU sample stamped 10 s ahead or behind -------------------------------------------------

class ImuTimeOutlier : public TimeFault, public ::testing::WithParamInterface<double> {};

TEST_P(ImuTimeOutlier, IsDroppedCountedAndHarmless) {
  const double jump = GetParam();
  const FaultRun r = run_fault(test_name(), [&](Lines& imu, Lines&) {
    const std::size_t i = first_after(imu, kPhases[1]);
    imu[i] = restamp_imu(imu[i], jump);
  });
  report("IMU sample stamped " + std::to_string(jump) + " s away", r);
  EXPECT_TRUE(r.summary.error.empty()) << r.summary.error;
  EXPECT_EQ(r.count("imu_time_outlier"), 1u);
  EXPECT_EQ(r.count("imu_out_of_order") + r.count("imu_clock_step"), 0u) << "the stream after it was refused";
  EXPECT_LE(r.ate, handled_bound());
  EXPECT_FALSE(r.summary.diverged) << r.summary.divergence;
}

INSTANTIATE_TEST_SUITE_P(AheadAndBehind, ImuTimeOutlier, ::testing::Values(10.0, -10.0),
                         [](const auto& info) { return info.param > 0 ? std::string("ahead") : std::string("behind"); });

// --- The IMU silent while the LiDAR runs --------------------------------------------------------

struct Dropout {
  double start;   ///< s: absolute time; the samples of (start, start + length] are removed
  double length;  ///< s
};

void PrintTo(const Dropout& d, std::ostream* os) { *os << d.length << " s IMU dropout after t=" << d.start; }

Lines without_imu(Lines imu, const Dropout& d) {
  Lines kept{imu[0]};
  for (std::size_t i = 1; i < imu.size(); ++i) {
    const double t = imu_time(imu[i]);
    if (t <= d.start || t > d.start + d.length) kept.push_back(imu[i]);
  }
  return kept;
}

class ImuDropout : public TimeFault, public ::testing::WithParamInterface<Dropout> {};

TEST_P(ImuDropout, IsCoastedAndReLocalised) {
  const Dropout d = GetParam();
  const FaultRun r = run_fault(test_name(), [&](Lines& imu, Lines&) { imu = without_imu(imu, d); });
  std::ostringstream what;
  PrintTo(d, &what);
  report(what.str(), r);
  EXPECT_TRUE(r.summary.error.empty()) << r.summary.error;
  EXPECT_EQ(r.count("imu_gap"), 1u);
  EXPECT_GE(r.count("scan_ahead_of_imu"), 1u) << "no scan ended inside the dropout";
  EXPECT_GE(r.count("recovery_scans"), 1u) << "the scans in the dropout were not re-localised";
  EXPECT_EQ(r.count("time_offset_at_bound"), 0u) << "the time offset ran to its bound across the dropout";
  EXPECT_LE(r.ate, handled_bound());
  EXPECT_EQ(r.summary.tracking, TrackingStatus::kTracking) << r.summary.tracking_reason;
}

std::vector<Dropout> dropouts() {
  std::vector<Dropout> v;
  for (double length : {0.3, 0.5, 0.7, 1.0}) {
    for (double start : kPhases) v.push_back({start, length});
  }
  return v;
}

INSTANTIATE_TEST_SUITE_P(Walking, ImuDropout, ::testing::ValuesIn(dropouts()),
                         [](const auto& info) { return "case" + std::to_string(info.index); });

// Negative control: with the scans in the dropout extrapolated on the held IMU measurement (as
// before coast_to), the bound above fails.
TEST_F(TimeFault, ADropoutNotCoastedLosesTheTrack) {
  const Dropout d{kPhases[1], 0.7};
  const FaultRun r = run_fault(test_name(), [&](Lines& imu, Lines&) { imu = without_imu(imu, d); },
                          {"estimator.divergence.coast_silent_imu=false"});
  report("0.7 s IMU dropout, coasting off", r);
  EXPECT_GT(r.ate, handled_bound());
}

// --- 1 s of NaN gyro ---------------------------------------------------------------------------

class NanGyro : public TimeFault, public ::testing::WithParamInterface<double> {};

TEST_P(NanGyro, IsRefusedAndTheGapCoasted) {
  const double start = GetParam();
  const FaultRun r = run_fault(test_name(), [&](Lines& imu, Lines&) {
    for (std::size_t i = 1; i < imu.size(); ++i) {
      const double t = imu_time(imu[i]);
      if (t <= start || t > start + 1.0) continue;
      std::vector<std::string> f;
      std::stringstream ss(imu[i]);
      for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
      imu[i] = f[0] + ",nan,nan,nan," + f[4] + "," + f[5] + "," + f[6];
    }
  });
  report("1 s of NaN gyro after t=" + std::to_string(start), r);
  EXPECT_EQ(r.count("nan_imu_sample") + r.count("imu_not_finite"), 200u);
  EXPECT_GE(r.count("recovery_scans"), 1u);
  EXPECT_LE(r.ate, handled_bound());
}

INSTANTIATE_TEST_SUITE_P(Walking, NanGyro, ::testing::Values(kPhases[0], kPhases[1]),
                         [](const auto& info) { return "case" + std::to_string(info.index); });

// --- Duplicate and swapped samples ---------------------------------------------------------------

TEST_F(TimeFault, DuplicateAndSwappedImuSamplesAreCountedAndHarmless) {
  const FaultRun r = run_fault(test_name(), [&](Lines& imu, Lines&) {
    const std::size_t dup = first_after(imu, kPhases[0]);
    imu.insert(imu.begin() + static_cast<std::ptrdiff_t>(dup), imu[dup]);
    const std::size_t swap = first_after(imu, kPhases[2]);
    std::swap(imu[swap], imu[swap + 1]);
  });
  report("a duplicate and a swapped pair of IMU samples", r);
  EXPECT_EQ(r.count("imu_duplicate"), 1u);
  EXPECT_EQ(r.count("imu_out_of_order"), 1u);
  EXPECT_EQ(r.count("imu_gap"), 0u);
  EXPECT_LE(r.ate, handled_bound());
}

// --- Both clocks step for the rest of the run ----------------------------------------------------

class ClockStep : public TimeFault, public ::testing::WithParamInterface<double> {};

TEST_P(ClockStep, IsDetectedAndReLocalised) {
  const double step = GetParam();
  const double at = 1005.0;  // between two scans
  const FaultRun r = run_fault(test_name(), [&](Lines& imu, Lines& scans) { step_clocks(imu, scans, at, step); }, {}, at,
                          step);
  report("clock step of " + std::to_string(step) + " s", r);
  EXPECT_TRUE(r.summary.error.empty()) << r.summary.error;
  EXPECT_GE(r.count("imu_clock_step"), 1u);
  EXPECT_GE(r.count("scan_clock_step"), 1u);
  EXPECT_FALSE(r.summary.diverged) << r.summary.divergence;
  EXPECT_LE(r.ate, handled_bound());
  // The state went on at the new time: poses on both sides of the step.
  std::size_t after = 0;
  for (const auto& p : r.summary.trajectory) after += std::abs(p.t - (at + step)) < std::abs(p.t - at) ? 1 : 0;
  EXPECT_GT(after, 40u);
}

INSTANTIATE_TEST_SUITE_P(ForwardAndBack, ClockStep, ::testing::Values(100.0, -100.0),
                         [](const auto& info) { return info.param > 0 ? std::string("forward") : std::string("back"); });

// Negative control: without the time checks (estimator.clock.enabled=false) every sample after a
// step back is refused; the run ends lost, and says so.
TEST_F(TimeFault, AClockStepWithoutTimeChecksEndsLost) {
  const FaultRun r = run_fault(test_name(), [&](Lines& imu, Lines& scans) { step_clocks(imu, scans, 1005.0, -100.0); },
                          {"estimator.clock.enabled=false"});
  report("clock step of -100 s, time checks off", r);
  EXPECT_TRUE(r.summary.diverged);
  EXPECT_EQ(r.summary.tracking, TrackingStatus::kLost);
  EXPECT_NE(r.summary.divergence.find("lost"), std::string::npos) << r.summary.divergence;
}

// --- fuse-run exit codes -----------------------------------------------------------------------

int run_cli(const std::string& args, std::string& output) {
  return run_command(std::string(FUSE_RUN_BIN) + " " + args + " --log-level off", output);
}

class FuseRunExitCode : public TimeFault {
 protected:
  void SetUp() override {
    TimeFault::SetUp();
    dir_ = fs::temp_directory_path() / ("fuse_exit_code_" + std::to_string(::getpid()) + "_" + test_name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(FuseRunExitCode, CleanRunIs0) {
  std::string out;
  EXPECT_EQ(run_cli("--config " + kConfig + " --input " + kSeqdir + " --out " + (dir_ / "o").string(), out), 0) << out;
  EXPECT_NE(out.find("tracking: tracking"), std::string::npos) << out;
}

TEST_F(FuseRunExitCode, DivergedRunIs3WithTheReason) {
  const fs::path input = faulty_sequence(kSeqdir, test_name(), [](Lines& imu, Lines& scans) { step_clocks(imu, scans, 1005.0, -100.0); });
  std::string out;
  const int code = run_cli("--config " + kConfig + " --input " + input.string() + " --out " + (dir_ / "o").string() +
                               " --set estimator.clock.enabled=false",
                           out);
  fs::remove_all(input);
  EXPECT_EQ(code, 3) << out;
  EXPECT_NE(out.find("diverged: lost"), std::string::npos) << out;
  EXPECT_NE(out.find("tracking_episode: lost"), std::string::npos) << out;
  EXPECT_TRUE(fs::exists(dir_ / "o" / "trajectory.tum")) << "the outputs are written all the same";
}

TEST_F(FuseRunExitCode, OutThatCannotBeCreatedIs1NamingThePath) {
  std::ofstream(dir_ / "a_file") << "x";
  const std::string out_dir = (dir_ / "a_file" / "out").string();  // below a regular file
  std::string out;
  EXPECT_EQ(run_cli("--config " + kConfig + " --input " + kSeqdir + " --out " + out_dir, out), 1) << out;
  EXPECT_NE(out.find(out_dir), std::string::npos) << out;
  EXPECT_EQ(out.find("scans:"), std::string::npos) << "the run started: " << out;
}

TEST_F(FuseRunExitCode, EmptyOrNonMapConfigIs2NamingTheFile) {
  for (const std::string text : {"", "# nothing but a comment\n", "- estimator\n"}) {
    const fs::path config = dir_ / "config.yaml";
    std::ofstream(config, std::ios::trunc) << text;
    std::string out;
    EXPECT_EQ(run_cli("--config " + config.string() + " --input " + kSeqdir + " --out " + (dir_ / "o").string(), out), 2)
        << "'" << text << "': " << out;
    EXPECT_NE(out.find(config.string()), std::string::npos) << out;
  }
}

}  // namespace
}  // namespace fuse

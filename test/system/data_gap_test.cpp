// A data gap while walking: the IMU samples and scans of 0.5–2.5 s are missing (what a restarted
// fuse-ingest or a lost link leaves), taken out of the 10 s corridor sequence at several phases of
// the handheld sway. The estimator coasts across the gap (StateTracker::coast_across_gap, at the
// rotation rate that the motion before the gap and the sample after it agree on), and the first
// scans after it are re-localised against the map (estimator.recovery). Truth is the simulator's.
//
// A lost track is off by metres; a survived gap stays within centimetres of the uninterrupted
// run (1.4–6.5 cm measured). Negative controls: without re-localisation, or coasting at one end's
// rotation rate (gap_rate_window = 0), some of these gaps lose the track.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

#include "fuse/eval/evaluate.hpp"
#include "fuse/eval/trajectory.hpp"
#include "runner.hpp"

namespace fuse {
namespace {

namespace fs = std::filesystem;

const std::string kSeqdir = std::string(FUSE_TEST_DATA) + "/seqdir10";
const std::string kConfig = std::string(FUSE_CONFIG_DIR) + "/mid360.yaml";
/// Loose: the survived gaps measure 1.4–6.5 cm, a lost track metres.
constexpr double kSurvivedAte = 0.10;

struct Gap {
  double start;   ///< s, absolute time of the last sample before the gap
  double length;  ///< s
};

void PrintTo(const Gap& g, std::ostream* os) { *os << "gap of " << g.length << " s after t=" << g.start; }

/// Copies a CSV file with its header line, keeping the rows for which keep(row) is true.
void copy_rows(const std::string& from, const fs::path& to, const std::function<bool(const std::string&)>& keep) {
  std::ifstream in(from);
  std::ofstream out(to);
  std::string line;
  std::getline(in, line);
  out << line << '\n';
  while (std::getline(in, line)) {
    if (keep(line)) out << line << '\n';
  }
}

/// The comma-separated field `i` of a row, as a number.
double field(const std::string& row, int i) {
  std::stringstream ss(row);
  std::string f;
  for (int k = 0; k <= i; ++k) std::getline(ss, f, ',');
  return std::stod(f);
}

/// A copy of the sequence `source` with the IMU samples and the scans of each gap (start, start +
/// length] removed (scans are shared through a link to the original raw/ folder).
fs::path sequence_with_gaps(const std::string& source, const std::vector<Gap>& gaps, const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("fuse_data_gap_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  fs::copy_file(source + "/calib.yaml", dir / "calib.yaml");
  fs::create_directory_symlink(fs::absolute(source + "/raw"), dir / "raw");
  auto keep = [&gaps](double t0, double t1, bool sample) {
    for (const Gap& g : gaps) {
      const double end = g.start + g.length;
      if (sample ? t0 > g.start && t0 <= end : t1 > g.start && t0 < end) return false;
    }
    return true;
  };
  copy_rows(source + "/imu.csv", dir / "imu.csv", [&](const std::string& row) {
    const double t = field(row, 0) * 1e-9;  // ns
    return keep(t, t, true);
  });
  copy_rows(source + "/scans.csv", dir / "scans.csv",  // idx, t_start, t_end
            [&](const std::string& row) { return keep(field(row, 1), field(row, 2), false); });
  return dir;
}

struct GapRun {
  RunSummary summary;
  double ate = 0.0;
};

GapRun run_with_gaps(const std::string& source, const std::vector<Gap>& gaps, const std::string& name,
                     const std::vector<std::string>& overrides = {}) {
  const fs::path dir = sequence_with_gaps(source, gaps, name);
  GapRun r;
  r.summary = run_offline(load_runner_config(kConfig, overrides), dir.string(), "");
  fs::remove_all(dir);
  if (!r.summary.trajectory.empty()) {
    r.ate = eval::evaluate(eval::read_tum(source + "/groundtruth.tum"), r.summary.trajectory, eval::EvaluationConfig{})
                .ate.rmse;
  }
  return r;
}

GapRun run_with_gap(const Gap& gap, const std::string& name, const std::vector<std::string>& overrides = {}) {
  return run_with_gaps(kSeqdir, {gap}, name, overrides);
}

std::uint64_t count_of(const std::map<std::string, std::uint64_t>& m, const std::string& key) {
  const auto it = m.find(key);
  return it == m.end() ? 0 : it->second;
}

class DataGap : public ::testing::TestWithParam<Gap> {
 protected:
  void SetUp() override {
    if (!fs::exists(kSeqdir + "/scans.csv")) GTEST_SKIP() << "fixture missing: " << kSeqdir;
  }
};

TEST_P(DataGap, IsCoastedAndReLocalised) {
  const Gap gap = GetParam();
  const GapRun r = run_with_gap(gap, ::testing::UnitTest::GetInstance()->current_test_info()->name());
  ASSERT_TRUE(r.summary.error.empty()) << r.summary.error;
  EXPECT_EQ(count_of(r.summary.estimator_counts, "imu_gap"), 1u);
  EXPECT_GE(count_of(r.summary.estimator_counts, "recovery_scans"), 1u) << "the scan after the gap was not re-localised";
  EXPECT_LT(r.ate, kSurvivedAte);
  RecordProperty("ate_m", std::to_string(r.ate));
  std::cout << "gap of " << gap.length << " s after t=" << gap.start << ": ATE " << r.ate << " m, "
            << count_of(r.summary.estimator_counts, "recovery_scans") << " re-localised scans\n";
}

INSTANTIATE_TEST_SUITE_P(Walking, DataGap,
                         ::testing::Values(Gap{1004.0, 0.5}, Gap{1004.0, 1.0}, Gap{1004.0, 1.4}, Gap{1005.03, 0.5},
                                           Gap{1005.03, 1.0}, Gap{1005.03, 1.4}, Gap{1007.2, 0.5}, Gap{1007.2, 1.0},
                                           Gap{1007.2, 1.4}, Gap{1004.0, 2.5}, Gap{1005.03, 2.5},
                                           Gap{1007.2, 2.5}),
                         [](const auto& info) { return "case" + std::to_string(info.index); });

// Negative controls: each mechanism is needed for some gap (so the bound above can fail).
TEST(DataGapControl, WithoutReLocalisationAGapLosesTheTrack) {
  if (!fs::exists(kSeqdir + "/scans.csv")) GTEST_SKIP() << "fixture missing: " << kSeqdir;
  const GapRun r = run_with_gap({1004.0, 1.4}, "no_recovery", {"estimator.recovery.enabled=false"});
  EXPECT_EQ(count_of(r.summary.estimator_counts, "recovery_scans"), 0u);
  EXPECT_TRUE(!r.summary.error.empty() || r.ate > 2 * kSurvivedAte) << "ATE " << r.ate;
}

// A restarted fuse-ingest leaves gaps of seconds (its downtime plus the restart backoff). Taken as
// a clock step (a gap longer than estimator.clock.max_gap_s) the state is not moved across it;
// coasted, it is (measured: 1.50 m against 2.0 cm for this 2.5 s gap).
TEST(DataGapControl, AGapTakenAsAClockStepLosesTheTrack) {
  if (!fs::exists(kSeqdir + "/scans.csv")) GTEST_SKIP() << "fixture missing: " << kSeqdir;
  const GapRun r = run_with_gap({1004.0, 2.5}, "as_clock_step", {"estimator.clock.max_gap_s=2"});
  ASSERT_TRUE(r.summary.error.empty()) << r.summary.error;
  EXPECT_GE(count_of(r.summary.estimator_counts, "imu_clock_step"), 1u);
  EXPECT_GT(r.ate, kSurvivedAte);
}

TEST(DataGapControl, CoastingAtOneEndsRotationRateLosesTheTrack) {
  if (!fs::exists(kSeqdir + "/scans.csv")) GTEST_SKIP() << "fixture missing: " << kSeqdir;
  // With the accelerometer levelling and the heading search on, even this gap is recovered: the
  // control isolates the rate by turning them off.
  const GapRun r = run_with_gap({1005.03, 1.0}, "end_rate",
                                {"estimator.divergence.gap_rate_window=0", "estimator.divergence.gap_level=false",
                                 "estimator.recovery.heading_hypotheses=1"});
  EXPECT_TRUE(!r.summary.error.empty() || r.ate > 2 * kSurvivedAte) << "ATE " << r.ate;
}

// Repeated short gaps on a map that has grown for minutes: what fuse-ingest restarts every few
// seconds leave (the chaos soak's kills). Each gap ends in a re-localisation; one that settles a
// little off (along the corridor, or tilted after a gap in a turn) and writes the space ahead into
// the map bends the map for good: later scans fit it (docs/chaos.md, "Map hold after a
// re-localisation"). With estimator.recovery.map_hold_distance the map grows only near the sensor
// until the estimate has settled. Truth is the simulator's. Measured (corridor, 180 s, these 20
// gaps of 0.2-1.2 s): 2.0 cm without gaps; with them 8.1 cm with the hold (8 m radius), 13.9 cm
// without it; the bound asks for a quarter less. (A 5 m radius gives 3.2 cm here but starves the
// map in the stairs scene, docs/chaos.md.)
TEST(RepeatedGaps, ReLocalisationsDoNotBendTheMap) {
  const std::string source = std::string(FUSE_TEST_DATA) + "/seqdir180";
  if (!fs::exists(source + "/scans.csv")) GTEST_SKIP() << "fixture missing: " << source;
  const std::vector<Gap> gaps = {{1010.0, 0.2},  {1014.7, 0.5},  {1024.3, 1.2}, {1034.3, 0.5}, {1040.3, 0.3},
                                 {1048.3, 1.0},  {1057.4, 0.8},  {1066.0, 1.2}, {1076.3, 1.0}, {1087.0, 1.0},
                                 {1097.7, 1.0},  {1104.3, 0.2},  {1113.7, 0.5}, {1121.0, 0.5}, {1130.9, 0.8},
                                 {1141.1, 1.0},  {1147.1, 0.3},  {1152.8, 0.2}, {1158.0, 0.3}, {1163.2, 1.0}};
  const GapRun clean = run_with_gaps(source, {}, "repeated_clean");
  const GapRun held = run_with_gaps(source, gaps, "repeated_held");
  const GapRun not_held = run_with_gaps(source, gaps, "repeated_not_held", {"estimator.recovery.map_hold_distance=0"});
  std::cout << "ATE without gaps " << clean.ate << " m; with 20 gaps " << held.ate << " m (" << held.ate / clean.ate
            << "x), without the map hold " << not_held.ate << " m (" << not_held.ate / clean.ate << "x)\n";
  ASSERT_TRUE(clean.summary.error.empty() && held.summary.error.empty()) << held.summary.error;
  EXPECT_GE(count_of(held.summary.estimator_counts, "map_hold"), 15u);
  EXPECT_LT(held.ate, 0.75 * not_held.ate);
  EXPECT_LT(held.ate, 5.0 * clean.ate);  // tracked throughout (a lost track is off by metres)
}

// A gap that hides a turn: 3 s of IMU and scans missing while the vehicle takes a 90° corner of
// the 180 s corridor. The coasted prior runs straight on past the corner, so the right heading
// tried about the coasted position fits poorly and a 180° one fits better (the corridor behind
// is mapped, the one ahead is not). With estimator.recovery.turn_through_gap each heading
// hypothesis is a turn taken during the gap, its position moved to the end of that turn's arc.
// Measured: 5.7 cm with it, 27 m without (2.0 cm without the gap).
TEST(DataGapInATurn, HeadingHypothesesTurnThroughTheGap) {
  const std::string source = std::string(FUSE_TEST_DATA) + "/seqdir180";
  if (!fs::exists(source + "/scans.csv")) GTEST_SKIP() << "fixture missing: " << source;
  const Gap corner{1055.5, 3.0};
  const GapRun turned = run_with_gaps(source, {corner}, "turn_through");
  const GapRun straight = run_with_gaps(source, {corner}, "turn_about", {"estimator.recovery.turn_through_gap=false"});
  std::cout << "ATE with the turn through the gap " << turned.ate << " m, turning about the coasted position "
            << straight.ate << " m\n";
  ASSERT_TRUE(turned.summary.error.empty()) << turned.summary.error;
  EXPECT_LT(turned.ate, 0.15);
  EXPECT_GT(straight.ate, 1.0);  // the control: the same gap without the turn model loses the track
}

}  // namespace
}  // namespace fuse

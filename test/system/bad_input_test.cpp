// Faulty inputs through the whole runner: NaN points, time going backwards, a 0.5 s IMU gap, a
// truncated file, an empty scan, a bad config key, a diverging filter. Each gets a clear message
// and a count; the run finishes or stops cleanly, never crashes.
#include <gtest/gtest.h>


#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "run_command.hpp"
#include "runner.hpp"

namespace fs = std::filesystem;

namespace fuse {
namespace {

const std::string kSeqdir = std::string(FUSE_TEST_DATA) + "/seqdir10";
const std::string kRecording = std::string(FUSE_TEST_DATA) + "/corridor60/recording.mcap";
const std::string kConfig = std::string(FUSE_CONFIG_DIR) + "/mid360.yaml";

class BadInputTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(kSeqdir + "/scans.csv")) << "fixture missing: " << kSeqdir;
    dir_ = fs::temp_directory_path() / ("fuse_bad_input_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::copy(kSeqdir, dir_, fs::copy_options::recursive);
  }
  void TearDown() override { fs::remove_all(dir_); }

  RunSummary run() { return run_offline(load_runner_config(kConfig), dir_.string(), ""); }
  std::vector<std::string> read_lines(const std::string& name) {
    std::ifstream f(dir_ / name);
    std::vector<std::string> lines;
    for (std::string l; std::getline(f, l);) lines.push_back(l);
    return lines;
  }
  void write_lines(const std::string& name, const std::vector<std::string>& lines) {
    std::ofstream f(dir_ / name, std::ios::trunc);
    for (const auto& l : lines) f << l << '\n';
  }
  fs::path scan_file(int index) {
    char name[32];
    std::snprintf(name, sizeof(name), "raw/%06d.bin", index);
    return dir_ / name;
  }

  fs::path dir_;
};

std::uint64_t count_of(const std::map<std::string, std::uint64_t>& m, const std::string& key) {
  const auto it = m.find(key);
  return it == m.end() ? 0 : it->second;
}

TEST_F(BadInputTest, NanPointsAreRemovedAndCounted) {
  std::fstream f(scan_file(50), std::ios::in | std::ios::out | std::ios::binary);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  f.write(reinterpret_cast<const char*>(&nan), sizeof(float));  // x of point 0
  f.seekp(24 + 4);
  f.write(reinterpret_cast<const char*>(&inf), sizeof(float));  // y of point 1
  f.close();
  const RunSummary s = run();
  EXPECT_TRUE(s.error.empty()) << s.error;
  EXPECT_EQ(count_of(s.input_rejected, "nan_points"), 2u);
  EXPECT_GT(s.scans_updated, 50u);
}

TEST_F(BadInputTest, ImuTimeGoingBackwardsIsDroppedAndCounted) {
  auto lines = read_lines("imu.csv");
  ASSERT_GT(lines.size(), 1500u);
  std::swap(lines[1200], lines[1201]);
  write_lines("imu.csv", lines);
  const RunSummary s = run();
  EXPECT_TRUE(s.error.empty()) << s.error;
  EXPECT_EQ(count_of(s.input_rejected, "imu_out_of_order"), 1u);
}

TEST_F(BadInputTest, HalfSecondImuGapIsFlaggedAndSurvived) {
  auto lines = read_lines("imu.csv");
  ASSERT_GT(lines.size(), 1700u);
  lines.erase(lines.begin() + 1500, lines.begin() + 1600);  // 100 samples at 200 Hz = 0.5 s, while walking
  write_lines("imu.csv", lines);
  const RunSummary s = run();
  EXPECT_EQ(count_of(s.estimator_counts, "imu_gap"), 1u);
  // Survived: either it finished, or it stopped cleanly with a divergence report.
  EXPECT_TRUE(s.error.empty() || s.diverged) << s.error;
  EXPECT_GT(s.scans_updated, 50u);
}

TEST_F(BadInputTest, EmptyScanIsCountedAndSkipped) {
  fs::resize_file(scan_file(40), 0);
  const RunSummary s = run();
  EXPECT_TRUE(s.error.empty()) << s.error;
  EXPECT_EQ(count_of(s.input_rejected, "empty_scan"), 1u);
  EXPECT_EQ(count_of(s.estimator_counts, "scan_empty"), 1u);
}

TEST_F(BadInputTest, ScanTimeGoingBackwardsIsDroppedAndCounted) {
  auto lines = read_lines("scans.csv");
  ASSERT_GT(lines.size(), 62u);
  // Scan 60 claims to lie before scan 59.
  std::ostringstream row;
  double t0 = 0, t1 = 0;
  std::sscanf(lines[60].c_str(), "%*d,%lf,%lf", &t0, &t1);
  row.precision(9);
  row << std::fixed << 60 << ',' << t0 - 0.5 << ',' << t1 - 0.5;
  lines[61] = row.str();
  write_lines("scans.csv", lines);
  const RunSummary s = run();
  EXPECT_TRUE(s.error.empty()) << s.error;
  EXPECT_EQ(count_of(s.input_rejected, "scan_out_of_order"), 1u);
}

TEST_F(BadInputTest, TruncatedScanFileStopsCleanlyNamingTheFile) {
  fs::resize_file(scan_file(30), 100);  // not a multiple of 24 bytes
  const RunSummary s = run();
  // The sequence directory is checked when it is opened, so the run stops before it starts.
  ASSERT_FALSE(s.error.empty());
  EXPECT_NE(s.error.find("000030.bin"), std::string::npos) << s.error;
}

TEST_F(BadInputTest, TruncatedRecordingStopsCleanly) {
  ASSERT_TRUE(fs::exists(kRecording)) << "fixture missing: " << kRecording;
  const fs::path cut = dir_ / "cut.mcap";
  fs::copy_file(kRecording, cut);
  fs::resize_file(cut, fs::file_size(cut) / 3);
  const RunSummary s = run_offline(load_runner_config(kConfig), cut.string(), "");
  EXPECT_FALSE(s.error.empty());
  EXPECT_GT(s.scans, 10u);  // the readable part was processed before the clear error
}

int run_cli(const std::string& args, std::string& output) {
  return run_command(std::string(FUSE_RUN_BIN) + " " + args, output);
}

/// Runs the fuse-run binary on the test's sequence directory with extra arguments.
int run_on(const fs::path& dir, const std::string& extra, std::string& output) {
  return run_cli("--config " + kConfig + " --input " + dir.string() + " --out " + (dir / "o").string() + " " + extra,
                 output);
}

TEST_F(BadInputTest, UnknownConfigKeyIsRefusedNamingTheKey) {
  std::string out;
  const int code = run_on(dir_, "--set estimator.update.max_iteratons=3", out);
  EXPECT_EQ(code, 2) << out;
  EXPECT_NE(out.find("estimator.update.max_iteratons"), std::string::npos) << out;
}

// One config file serves fuse-run and the services: fuse-run leaves every service section to
// the services (they validate it) and still refuses a section nobody reads.
TEST(RunnerConfig, AcceptsEveryServiceSectionAndRefusesAnUnknownOne) {
  EXPECT_NO_THROW(load_runner_config(kConfig, {"transport.domain_id=3", "ingest.rate=2", "state.imu_buffer_s=5",
                                               "update.max_unacked=20", "map_server.snapshot_every=10",
                                               "scheduling.state_slice_us=100", "health.period_s=1"}));
  try {
    load_runner_config(kConfig, {"planner.rate=10"});
    ADD_FAILURE() << "an unknown section was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("planner"), std::string::npos) << e.what();
  }
}

TEST_F(BadInputTest, BadConfigValueIsRefusedNamingTheKey) {
  std::string out;
  const int code = run_on(dir_, "--set estimator.preprocess.voxel_size=-1", out);
  EXPECT_EQ(code, 2) << out;
  EXPECT_NE(out.find("estimator.preprocess.voxel_size"), std::string::npos) << out;
}

TEST_F(BadInputTest, DivergenceIsReportedAsAnError) {
  std::string out;
  const int code = run_on(dir_, "--set estimator.divergence.max_position_std=1e-6 --log-level off", out);
  EXPECT_EQ(code, 3) << out;
  EXPECT_NE(out.find("diverged"), std::string::npos) << out;
}

}  // namespace
}  // namespace fuse

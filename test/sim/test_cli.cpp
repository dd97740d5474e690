// Command line parsing, exit codes of the executable, determinism of the written files and the
// sequence-directory output.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <sys/wait.h>

#include "fuse/sim/cli.hpp"

using namespace fuse::sim;
namespace fs = std::filesystem;

namespace {

int run(const std::string& args) {
  const std::string cmd = std::string(FUSE_SIM_EXE) + " " + args + " >/dev/null 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("fuse_sim_test_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

std::string line_with(const std::string& text, const std::string& key) {
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line))
    if (line.find(key) != std::string::npos) return line;
  return "";
}

}  // namespace

TEST(SimCli, ParsesValidArguments) {
  const CliCommand c = parse_cli({"--scenario", "room", "--seed", "7", "--duration", "2.5", "--lidar", "spinning32",
                                  "--format", "seqdir", "--out", "x"});
  EXPECT_FALSE(c.help);
  EXPECT_EQ(c.options.scenario, "room");
  EXPECT_EQ(c.options.seed, 7u);
  EXPECT_EQ(c.options.world_seed, 7u);  // defaults to --seed
  EXPECT_DOUBLE_EQ(*c.options.duration_s, 2.5);
  EXPECT_EQ(c.options.lidar, "spinning32");
  EXPECT_EQ(c.options.format, OutputFormat::kSeqdir);
  EXPECT_EQ(parse_cli({"--scenario", "room", "--seed", "7", "--world-seed", "3", "--out", "x"}).options.world_seed,
            3u);
  EXPECT_TRUE(parse_cli({"--help"}).help);
  EXPECT_EQ(parse_cli({"--scenario", "corridor", "--seed", "1", "--laps", "3", "--out", "x"}).options.laps, 3);
  EXPECT_EQ(c.options.laps, 1);
}

TEST(SimCli, RejectsBadArguments) {
  const std::vector<std::vector<std::string>> bad = {
      {},
      {"--scenario", "corridor", "--out", "x"},                                 // missing --seed
      {"--scenario", "corridor", "--seed", "1"},                                // missing --out
      {"--seed", "1", "--out", "x"},                                            // missing --scenario
      {"--scenario", "mall", "--seed", "1", "--out", "x"},                      // unknown scenario
      {"--scenario", "corridor", "--seed", "-1", "--out", "x"},                 // negative seed
      {"--scenario", "corridor", "--seed", "1x", "--out", "x"},                 // junk
      {"--scenario", "corridor", "--seed", "99999999999999999999999", "--out", "x"},  // overflow
      {"--scenario", "corridor", "--seed", "1", "--duration", "0", "--out", "x"},
      {"--scenario", "corridor", "--seed", "1", "--duration", "nan", "--out", "x"},
      {"--scenario", "corridor", "--seed", "1", "--duration", "0.05", "--out", "x"},  // < one frame
      {"--scenario", "corridor", "--seed", "1", "--duration", "3s", "--out", "x"},
      {"--scenario", "corridor", "--seed", "1", "--lidar", "hdl64", "--out", "x"},
      {"--scenario", "corridor", "--seed", "1", "--format", "bag", "--out", "x"},
      {"--scenario", "corridor", "--seed", "1", "--out"},                       // missing value
      {"--scenario", "corridor", "--seed", "1", "--seed", "2", "--out", "x"},   // repeated
      {"--scenario", "corridor", "--seed", "1", "--out", "x", "--verbose"},     // unknown
      {"--scenario", "corridor", "--seed", "1", "--laps", "0", "--out", "x"},
      {"--scenario", "corridor", "--seed", "1", "--laps", "101", "--out", "x"},
      {"--scenario", "room", "--seed", "1", "--laps", "2", "--out", "x"},       // not a loop
  };
  for (const auto& args : bad) EXPECT_THROW(parse_cli(args), CliError) << ::testing::PrintToString(args);
}

TEST(SimCli, ExitCodes) {
  EXPECT_EQ(run("--help"), 0);
  EXPECT_EQ(run(""), 2);
  EXPECT_EQ(run("--scenario corridor --seed abc --out /nonexistent"), 2);
  EXPECT_EQ(run("--scenario corridor --seed 1 --duration -3 --out x"), 2);
  EXPECT_EQ(run("--bogus"), 2);
  const fs::path file = temp_dir("file");
  std::ofstream(file.string()) << "not a directory";
  EXPECT_EQ(run("--scenario room --seed 1 --duration 0.5 --out " + file.string()), 1);
  fs::remove(file);
}

TEST(SimCli, SameArgumentsGiveIdenticalBytesOtherSeedOtherNoiseSameWorld) {
  const fs::path a = temp_dir("a"), b = temp_dir("b"), c = temp_dir("c");
  const std::string args = "--scenario corridor --duration 1.2 --world-seed 5 --out ";
  ASSERT_EQ(run(args + a.string() + " --seed 1"), 0);
  ASSERT_EQ(run(args + b.string() + " --seed 1"), 0);
  ASSERT_EQ(run(args + c.string() + " --seed 2"), 0);
  for (const char* f : {"recording.mcap", "groundtruth.tum", "scenario.yaml"}) {
    ASSERT_TRUE(fs::exists(a / f)) << f;
    EXPECT_GT(fs::file_size(a / f), 100u) << f;
    EXPECT_EQ(slurp(a / f), slurp(b / f)) << f << " differs between identical runs";
  }
  EXPECT_NE(slurp(a / "recording.mcap"), slurp(c / "recording.mcap"));
  const std::string ya = slurp(a / "scenario.yaml"), yc = slurp(c / "scenario.yaml");
  EXPECT_NE(line_with(ya, "initial_gyro_bias"), line_with(yc, "initial_gyro_bias"));
  EXPECT_EQ(line_with(ya, "features:"), line_with(yc, "features:"));
  EXPECT_EQ(line_with(ya, "boxes:"), line_with(yc, "boxes:"));
  // groundtruth.tum: 1.2 s at 200 Hz plus the start sample, after one header line.
  std::istringstream gt(slurp(a / "groundtruth.tum"));
  std::string line;
  int rows = 0;
  while (std::getline(gt, line)) rows += line[0] != '#';
  EXPECT_EQ(rows, 241);
  for (const fs::path& d : {a, b, c}) fs::remove_all(d);
}

TEST(SimCli, WritesASequenceDirectory) {
  const fs::path d = temp_dir("seqdir");
  ASSERT_EQ(run("--scenario stairs --seed 3 --duration 0.5 --format seqdir --out " + d.string()), 0);
  for (const char* f : {"scans.csv", "imu.csv", "calib.yaml", "groundtruth.tum", "scenario.yaml", "raw/000004.bin"})
    EXPECT_TRUE(fs::exists(d / f)) << f;
  EXPECT_FALSE(fs::exists(d / "raw/000005.bin"));
  // 6 floats (24 bytes) per point, about 20k points per scan.
  const auto bytes = fs::file_size(d / "raw/000000.bin");
  EXPECT_EQ(bytes % 24, 0u);
  EXPECT_GT(bytes / 24, 19000u);
  fs::remove_all(d);
}

// Command line parsing (messages naming the flag, defaults, --help / --version), exit codes of
// the executable, determinism of the written files and the sequence-directory output.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <utility>
#include <vector>

#include "fuse/sim/cli.hpp"
#include "../cli_capture.hpp"

using namespace fuse::sim;
namespace fs = std::filesystem;

namespace {

constexpr int kExitUsage = 2;  // fuse::cli::kExitUsage: a usage error

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

/// parse_arguments on the command line "fuse-sim ARGS...": its result and what it printed.
struct Parsed {
  std::optional<int> code;  ///< std::nullopt: the simulation would run
  SimOptions options;
  std::string out, err;
};

Parsed parse(std::vector<std::string> args) {
  Parsed p;
  const fuse::test::CapturedCli c = fuse::test::run_cli_parser(
      "fuse-sim", std::move(args), [&](int argc, char** argv) { return parse_arguments(argc, argv, p.options); });
  p.code = c.code;
  p.out = c.out;
  p.err = c.err;
  return p;
}

}  // namespace

TEST(SimCli, ParsesValidArguments) {
  const Parsed c = parse({"--scenario", "room", "--seed", "7", "--duration", "2.5", "--lidar", "spinning32", "--format",
                          "seqdir", "--out", "x"});
  ASSERT_FALSE(c.code) << c.err;
  EXPECT_EQ(c.options.scenario, "room");
  EXPECT_EQ(c.options.seed, 7u);
  EXPECT_EQ(c.options.world_seed, 7u);  // defaults to --seed
  EXPECT_DOUBLE_EQ(*c.options.duration_s, 2.5);
  EXPECT_EQ(c.options.lidar, "spinning32");
  EXPECT_EQ(c.options.format, OutputFormat::kSeqdir);
  EXPECT_EQ(c.options.out_dir, "x");
  EXPECT_EQ(c.options.laps, 1);
  EXPECT_EQ(parse({"--scenario", "room", "--seed", "7", "--world-seed", "3", "--out", "x"}).options.world_seed, 3u);
  EXPECT_EQ(parse({"--scenario", "corridor", "--seed", "1", "--laps", "3", "--out", "x"}).options.laps, 3);
  // Defaults; --opt=value works too; an option given twice takes the later value (the convention).
  const Parsed d = parse({"--scenario=corridor", "--seed", "1", "--seed=2", "--out", "y"});
  ASSERT_FALSE(d.code) << d.err;
  EXPECT_EQ(d.options.seed, 2u);
  EXPECT_EQ(d.options.world_seed, 2u);
  EXPECT_FALSE(d.options.duration_s);
  EXPECT_EQ(d.options.lidar, "mid360");
  EXPECT_EQ(d.options.format, OutputFormat::kMcap);
}

TEST(SimCli, ParsesTheVehicleOptions) {
  const Parsed u =
      parse({"--scenario", "urban", "--seed", "3", "--lidar", "spinning64", "--traffic", "off", "--out", "x"});
  ASSERT_FALSE(u.code) << u.err;
  EXPECT_EQ(u.options.scenario, "urban");
  EXPECT_EQ(u.options.lidar, "spinning64");
  EXPECT_FALSE(u.options.traffic);
  EXPECT_TRUE(parse({"--scenario", "urban", "--seed", "3", "--out", "x"}).options.traffic);  // on by default
  EXPECT_TRUE(parse({"--scenario", "urban", "--seed", "3", "--traffic", "on", "--out", "x"}).options.traffic);
  EXPECT_EQ(parse({"--scenario", "urban", "--seed", "3", "--stops", "2", "--out", "x"}).options.stops, 2);
  EXPECT_EQ(parse({"--scenario", "urban", "--seed", "3", "--out", "x"}).options.stops, 0);
  // The classifier needs no --out; its tolerance defaults to 0.3 m.
  const Parsed c = parse({"--scenario", "urban", "--seed", "3", "--classify-map", "map.pcd"});
  ASSERT_FALSE(c.code) << c.err;
  EXPECT_EQ(c.options.classify_map, "map.pcd");
  EXPECT_DOUBLE_EQ(c.options.classify_tolerance_m, 0.3);
  EXPECT_DOUBLE_EQ(
      parse({"--scenario", "urban", "--seed", "3", "--classify-map", "m.ply", "--classify-tolerance", "0.5"})
          .options.classify_tolerance_m,
      0.5);
  EXPECT_EQ(parse({"--scenario", "campus", "--seed", "3", "--lidar", "spinning64", "--out", "x"}).options.lidar,
            "spinning64");
}

TEST(SimCli, HelpAndVersionExitZeroOnStdout) {
  const Parsed help = parse({"--help"});
  EXPECT_EQ(help.code, 0);
  EXPECT_NE(help.out.find("Usage: fuse-sim"), std::string::npos) << help.out;
  EXPECT_NE(help.out.find("--world-seed"), std::string::npos) << help.out;
  const Parsed version = parse({"--version"});
  EXPECT_EQ(version.code, 0);
  EXPECT_EQ(version.out.rfind("fuse-sim (FUSE-SLAM) ", 0), 0u) << version.out;
}

TEST(SimCli, RejectsBadArgumentsNamingTheFlag) {
  // Each bad command line and what the message (on stderr, exit code 2) must contain.
  const std::vector<std::pair<std::vector<std::string>, std::string>> bad = {
      {{}, "missing --scenario"},
      {{"--scenario", "corridor", "--out", "x"}, "missing --seed"},
      {{"--scenario", "corridor", "--seed", "1"}, "missing --out"},
      {{"--seed", "1", "--out", "x"}, "missing --scenario"},
      {{"--scenario", "mall", "--seed", "1", "--out", "x"}, "--scenario: unknown scenario 'mall'"},
      {{"--scenario", "corridor", "--seed", "-1", "--out", "x"}, "--seed: expected a non-negative integer"},
      {{"--scenario", "corridor", "--seed", "1x", "--out", "x"}, "--seed: expected a non-negative integer"},
      {{"--scenario", "corridor", "--seed", "99999999999999999999999", "--out", "x"}, "--seed: '9999"},  // overflow
      {{"--scenario", "corridor", "--seed", "1", "--world-seed", "w", "--out", "x"}, "--world-seed: expected"},
      {{"--scenario", "corridor", "--seed", "1", "--duration", "0", "--out", "x"}, "--duration: must be between"},
      {{"--scenario", "corridor", "--seed", "1", "--duration", "nan", "--out", "x"}, "--duration: must be between"},
      {{"--scenario", "corridor", "--seed", "1", "--duration", "0.05", "--out", "x"}, "--duration: must be"},
      {{"--scenario", "corridor", "--seed", "1", "--duration", "3s", "--out", "x"}, "--duration: expected a number"},
      {{"--scenario", "corridor", "--seed", "1", "--lidar", "hdl64", "--out", "x"}, "--lidar: unknown model"},
      {{"--scenario", "corridor", "--seed", "1", "--format", "bag", "--out", "x"}, "--format: unknown format"},
      {{"--scenario", "corridor", "--seed", "1", "--out"}, "--out"},  // missing value
      {{"--scenario", "corridor", "--seed", "1", "--out", ""}, "--out: empty directory name"},
      {{"--scenario", "corridor", "--seed", "1", "--out", "x", "--verbose"}, "unknown option --verbose"},
      {{"--scenario", "corridor", "--seed", "1", "--laps", "0", "--out", "x"}, "--laps: must be between 1 and 100"},
      {{"--scenario", "corridor", "--seed", "1", "--laps", "101", "--out", "x"}, "--laps: must be between 1 and 100"},
      {{"--scenario", "room", "--seed", "1", "--laps", "2", "--out", "x"}, "--laps: only the corridor"},  // no loop
      {{"--scenario", "room", "--seed", "1", "--imu-time-offset", "2", "--out", "x"}, "--imu-time-offset: expected a"},
      {{"--scenario", "room", "--seed", "1", "--imu-time-offset", "5ms", "--out", "x"}, "--imu-time-offset: expected"},
      {{"--scenario", "urban", "--seed", "1", "--traffic", "maybe", "--out", "x"}, "--traffic: expected on or off"},
      {{"--scenario", "urban", "--seed", "1", "--stops", "-1", "--out", "x"}, "--stops: expected a non-negative integer"},
      {{"--scenario", "urban", "--seed", "1", "--stops", "101", "--out", "x"}, "--stops: must be between 0 and 100"},
      {{"--scenario", "campus", "--seed", "1", "--stops", "1", "--out", "x"},
       "--stops: the scenario 'campus' does not stop at crossings"},
      {{"--scenario", "corridor", "--seed", "1", "--traffic", "off", "--out", "x"},
       "--traffic: the scenario 'corridor' has no moving objects"},
      {{"--scenario", "urban", "--seed", "1", "--classify-map", "m.ply", "--classify-tolerance", "0"},
       "--classify-tolerance: expected a distance"},
      {{"--scenario", "urban", "--seed", "1", "--classify-map", "m.ply", "--classify-tolerance", "x"},
       "--classify-tolerance: expected a distance"},
      {{"--scenario", "urban", "--seed", "1", "--classify-tolerance", "0.5", "--out", "x"},
       "--classify-tolerance: only with --classify-map"},
      {{"--scenario", "urban", "--seed", "1", "--classify-map", ""}, "--classify-map: empty file name"},
      {{"--scenario", "urban", "--seed", "1"}, "missing --out"},
  };
  for (const auto& [args, message] : bad) {
    const Parsed p = parse(args);
    EXPECT_EQ(p.code, kExitUsage) << ::testing::PrintToString(args);
    EXPECT_NE(p.err.find("fuse-sim: " + message), std::string::npos) << ::testing::PrintToString(args) << "\n" << p.err;
  }
}

TEST(SimCli, ExitCodes) {
  EXPECT_EQ(run("--help"), 0);
  EXPECT_EQ(run("--version"), 0);
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

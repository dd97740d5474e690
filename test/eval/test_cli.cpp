// The fuse-eval binary: JSON and text output, exit code 2 on bad arguments and files.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "fuse/eval/trajectory.hpp"
#include "test_helpers.hpp"

namespace fuse::eval {
namespace {

struct ToolRun {
  int exit_code = -1;
  std::string out;
  std::string err;
};

/// Runs fuse-eval with `args` (already shell-quoted), capturing stdout and stderr.
ToolRun run_tool(const std::string& args) {
  const test::TempFile err_file("");
  const std::string command = std::string("'") + FUSE_EVAL_BINARY + "' " + args + " 2>'" + err_file.path() + "'";
  ToolRun run;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return run;
  char buffer[4096];
  std::size_t n = 0;
  while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) run.out.append(buffer, n);
  const int status = pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream err(err_file.path());
  std::stringstream text;
  text << err.rdbuf();
  run.err = text.str();
  return run;
}

/// A flat JSON object of numbers and nulls, as fuse-eval writes it.
bool is_flat_json_object(const std::string& s) {
  static const std::regex object(
      R"(^\{("[a-z_0-9]+": (-?[0-9]+(\.[0-9]+)?|null))(, "[a-z_0-9]+": (-?[0-9]+(\.[0-9]+)?|null))*\}\n?$)");
  return std::regex_match(s, object);
}

double json_number(const std::string& json, const std::string& key) {
  const std::string pattern = "\"" + key + "\": ";
  const auto at = json.find(pattern);
  if (at == std::string::npos) return std::nan("");
  return std::strtod(json.c_str() + at + pattern.size(), nullptr);
}

/// Ground truth (a helix) and an estimate with a small lateral offset, written as TUM files.
struct SyntheticPair {
  test::TempFile gt{""};
  test::TempFile est{""};
  SyntheticPair() {
    Trajectory g = test::circle(5.0, 121);
    for (std::size_t i = 0; i < g.size(); ++i) g[i].p.z() = 0.01 * static_cast<double>(i);
    Trajectory e = g;
    for (std::size_t i = 0; i < e.size(); ++i) e[i].p.y() += (i % 2 == 0 ? 0.05 : -0.05);
    write_tum(gt.path(), g);
    write_tum(est.path(), e);
  }
};

TEST(Cli, JsonOutputParses) {
  const SyntheticPair files;
  const ToolRun run = run_tool("--gt '" + files.gt.path() + "' --est '" + files.est.path() + "' --json --delta 2");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(is_flat_json_object(run.out)) << run.out;
  EXPECT_EQ(json_number(run.out, "matched_poses"), 121.0);
  EXPECT_GT(json_number(run.out, "ate_rmse_m"), 0.01);
  EXPECT_LT(json_number(run.out, "ate_rmse_m"), 0.06);
  EXPECT_GT(json_number(run.out, "rpe_pairs"), 0.0);
}

TEST(Cli, TextOutputIsNameValueLines) {
  const SyntheticPair files;
  const ToolRun run = run_tool("--gt '" + files.gt.path() + "' --est '" + files.est.path() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  static const std::regex lines(R"(^([a-z_0-9]+: (-?[0-9]+(\.[0-9]+)?|nan)\n)+$)");
  EXPECT_TRUE(std::regex_match(run.out, lines)) << run.out;
  EXPECT_NE(run.out.find("ate_rmse_m: "), std::string::npos);
}

TEST(Cli, MissingFileExitsWithTwo) {
  const SyntheticPair files;
  const ToolRun run = run_tool("--gt /nonexistent/fuse_eval_gt.txt --est '" + files.est.path() + "'");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_TRUE(run.out.empty());
  EXPECT_NE(run.err.find("/nonexistent/fuse_eval_gt.txt"), std::string::npos) << run.err;
}

TEST(Cli, BadArgumentsExitWithTwo) {
  const SyntheticPair files;
  const std::string both = "--gt '" + files.gt.path() + "' --est '" + files.est.path() + "' ";
  for (const std::string& args : {std::string(""), "--gt '" + files.gt.path() + "'", both + "--format euroc",
                                  both + "--delta abc", both + "--delta -1", both + "--t-max-diff nan",
                                  both + "--align affine", both + "--bogus", both + "--delta"}) {
    const ToolRun run = run_tool(args);
    EXPECT_EQ(run.exit_code, 2) << args;
    EXPECT_NE(run.err.find("fuse-eval: "), std::string::npos) << args << ": " << run.err;
  }
}

TEST(Cli, MalformedFileExitsWithTwoNamingTheLine) {
  const SyntheticPair files;
  const test::TempFile bad("0 0 0 0 0 0 0 1\n1 0 0 zero 0 0 0 1\n");
  const ToolRun run = run_tool("--gt '" + files.gt.path() + "' --est '" + bad.path() + "'");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find(bad.path() + ":2:"), std::string::npos) << run.err;
}

TEST(Cli, KittiOracleThroughTheBinary) {
  const std::string dir = std::string(FUSE_SHARED_DATA) + "/trajectories/";
  if (!std::filesystem::exists(dir + "KITTI_00_gt.txt")) GTEST_SKIP() << "shared test data absent: " << dir;
  const ToolRun run = run_tool("--format kitti --json --delta 100 --gt '" + dir + "KITTI_00_gt.txt' --est '" + dir +
                           "KITTI_00_ORB.txt'");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(is_flat_json_object(run.out)) << run.out;
  EXPECT_NEAR(json_number(run.out, "ate_rmse_m"), 1.3034, 1e-3);
  EXPECT_EQ(json_number(run.out, "matched_poses"), 4541.0);
}

}  // namespace
}  // namespace fuse::eval

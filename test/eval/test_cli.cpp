// The fuse-eval binary: JSON and text output, exit code 2 on bad arguments and files.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <vector>

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
/// `env` (e.g. "PATH=/x ") is put before the command.
ToolRun run_tool(const std::string& args, const std::string& env = "") {
  const test::TempFile err_file("");
  const std::string command = env + "'" + FUSE_EVAL_BINARY + "' " + args + " 2>'" + err_file.path() + "'";
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

/// fuse-run's timing.csv for `n` scans at 10 Hz, scan i taking 2 + (i % 5) ms.
std::string timing_csv(int n) {
  std::string text = "scan,t,points_in,points_kept,deskew_ms,association_ms,update_ms,map_ms,total_ms\n";
  for (int i = 0; i < n; ++i) {
    text += std::to_string(i) + "," + std::to_string(100.0 + 0.1 * i) + ",1000,500,0.1,0.5,0.5,0.1," +
            std::to_string(2 + i % 5) + ".0\n";
  }
  return text;
}

/// Rows of a whitespace-separated data file, '#' lines skipped.
std::vector<std::vector<double>> read_rows(const std::string& path) {
  std::vector<std::vector<double>> rows;
  std::ifstream f(path);
  std::string line;
  while (std::getline(f, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    std::vector<double> row;
    for (double v = 0; in >> v;) row.push_back(v);
    rows.push_back(row);
  }
  return rows;
}

TEST(Cli, PlotDrawsEveryFigureFromTheErrorsItPrints) {
  const SyntheticPair files;
  const test::TempFile timing(timing_csv(50), ".csv");
  const std::string dir = files.gt.path() + "_plots";
  const ToolRun run = run_tool("--gt '" + files.gt.path() + "' --est '" + files.est.path() +
                               "' --json --delta 2 --plot '" + dir + "' --timing '" + timing.path() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  for (const char* figure : {"trajectory_top", "trajectory_side", "ape", "rpe", "scan_time"}) {
    const std::string svg = dir + "/" + figure + ".svg";
    std::ifstream f(svg);
    std::stringstream text;
    text << f.rdbuf();
    EXPECT_NE(text.str().find("<svg"), std::string::npos) << svg;
    EXPECT_NE(text.str().find("</svg>"), std::string::npos) << svg << " is cut short";
    EXPECT_NE(run.err.find("wrote " + svg), std::string::npos) << run.err;
  }
  // The figures' data are the errors the statistics were made of.
  const auto ape = read_rows(dir + "/ape.dat");
  ASSERT_EQ(ape.size(), 121u);
  double ape_max = 0.0, rot_max = 0.0, distance = 0.0;
  for (const auto& row : ape) {
    ASSERT_EQ(row.size(), 4u);
    EXPECT_GE(row[0], distance);  // distance travelled never decreases
    distance = row[0];
    ape_max = std::max(ape_max, row[2]);
    rot_max = std::max(rot_max, row[3]);
  }
  EXPECT_NEAR(ape_max, json_number(run.out, "ate_max_m"), 1e-6);
  EXPECT_NEAR(rot_max, json_number(run.out, "ate_rot_max_deg"), 1e-6);
  EXPECT_NEAR(distance, json_number(run.out, "path_length_m"), 1e-5);
  EXPECT_EQ(static_cast<double>(read_rows(dir + "/rpe.dat").size()), json_number(run.out, "rpe_pairs"));
  const auto trajectory = read_rows(dir + "/trajectory.dat");
  ASSERT_EQ(trajectory.size(), 121u);
  const Trajectory gt = read_tum(files.gt.path());
  EXPECT_NEAR(trajectory[7][2], gt[7].p.x(), 1e-6);  // reference x, y, z in columns 3-5
  EXPECT_NEAR(trajectory[7][4], gt[7].p.z(), 1e-6);
  const auto times = read_rows(dir + "/scan_time.dat");
  ASSERT_EQ(times.size(), 50u);
  EXPECT_NEAR(times[49][0], 4.9, 1e-6);
  EXPECT_NEAR(times[49][1], 6.0, 1e-9);
  std::filesystem::remove_all(dir);
}

TEST(Cli, PlotFailuresAreNamed) {
  const SyntheticPair files;
  const std::string both = "--gt '" + files.gt.path() + "' --est '" + files.est.path() + "' ";
  const std::string dir = files.gt.path() + "_plots";
  // --timing without --plot, and a timing file with a bad row: usage and input errors (2).
  EXPECT_EQ(run_tool(both + "--timing '" + files.gt.path() + "'").exit_code, 2);
  const test::TempFile bad("scan,t,total_ms\n0,1.0,2.0\n1,1.1,fast\n", ".csv");
  const ToolRun bad_run = run_tool(both + "--plot '" + dir + "' --timing '" + bad.path() + "'");
  EXPECT_EQ(bad_run.exit_code, 2);
  EXPECT_NE(bad_run.err.find(bad.path() + ":3: 'fast' is not a finite number"), std::string::npos) << bad_run.err;
  const test::TempFile no_column("scan,t\n0,1.0\n", ".csv");
  EXPECT_NE(run_tool(both + "--plot '" + dir + "' --timing '" + no_column.path() + "'").err.find("no column 'total_ms'"),
            std::string::npos);
  // No gnuplot on PATH: the evaluation is printed, the plots fail with exit code 1 and say why.
  const ToolRun no_gnuplot = run_tool("--gt '" + files.gt.path() + "' --est '" + files.est.path() + "' --plot '" +
                                      dir + "'", "PATH=/nonexistent ");
  EXPECT_EQ(no_gnuplot.exit_code, 1);
  EXPECT_NE(no_gnuplot.out.find("ate_rmse_m: "), std::string::npos);
  EXPECT_NE(no_gnuplot.err.find("gnuplot-nox"), std::string::npos) << no_gnuplot.err;
  std::filesystem::remove_all(dir);
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

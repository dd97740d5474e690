// fuse-map-export: runs the tool on a map directory and on a snapshot file and reads the written
// clouds back with PCL; bad arguments and unreadable maps give exit code 2.
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <fstream>
#include <optional>
#include <random>
#include <string>

#include "fuse/map/map_server_core.hpp"
#include "test_files.hpp"

namespace fuse {
namespace {

using test::TempDir;

struct ToolRun {
  int exit_code = -1;
  std::string out;  ///< stdout and stderr
};

ToolRun run_export(const std::string& arguments) {
  const std::string command = std::string(FUSE_MAP_EXPORT) + " " + arguments + " 2>&1";
  ToolRun run;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return run;
  std::array<char, 512> buffer{};
  while (std::fgets(buffer.data(), buffer.size(), pipe) != nullptr) run.out += buffer.data();
  const int status = ::pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

std::string quoted(const std::filesystem::path& p) { return "'" + p.string() + "'"; }

std::vector<Eigen::Vector3f> scan(std::uint64_t sequence) {
  std::mt19937 rng(static_cast<std::uint32_t>(sequence));
  std::uniform_real_distribution<float> u(-10.f, 10.f);
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 300; ++i) points.emplace_back(u(rng) + static_cast<float>(sequence), u(rng), 0.2f * u(rng));
  return points;
}

/// A map directory with a snapshot and journal records after it; returns the map it holds.
PointMap make_map_dir(const std::filesystem::path& dir) {
  MapServerConfig config;
  config.directory = dir.string();
  config.policy.min_point_distance = 0.4;
  MapServerCore core(config);
  for (std::uint64_t s = 1; s <= 4; ++s) core.apply(1, s, 0.0, scan(s));
  core.save();
  for (std::uint64_t s = 5; s <= 6; ++s) core.apply(1, s, 0.0, scan(s));
  return core.map();
}

/// A map of `scans` scans saved as a snapshot file in dir (the map directory beside it).
struct SavedMap {
  PointMap map;
  std::filesystem::path snapshot;
};
SavedMap saved_snapshot(TempDir& dir, std::uint64_t scans, std::optional<double> chunk_size = std::nullopt) {
  MapServerConfig config;
  config.directory = (dir / "map").string();
  if (chunk_size) config.chunk_size = *chunk_size;
  MapServerCore core(config);
  for (std::uint64_t s = 1; s <= scans; ++s) core.apply(7, s, 0.0, scan(s));
  const auto snapshot = core.save(dir / "saved.snapshot");
  return {core.map(), snapshot};
}

std::vector<std::array<float, 3>> sorted_points(const PointMap& map) {
  std::vector<std::array<float, 3>> out;
  map.for_each_chunk([&](const PointChunk& c) {
    for (const auto& p : c.points) out.push_back({p.x(), p.y(), p.z()});
  });
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::array<float, 3>> sorted_points(const pcl::PointCloud<pcl::PointXYZ>& cloud) {
  std::vector<std::array<float, 3>> out;
  for (const auto& p : cloud) out.push_back({p.x, p.y, p.z});
  std::sort(out.begin(), out.end());
  return out;
}

TEST(MapExport, MapDirectoryToPcdHoldsSnapshotAndJournal) {
  TempDir dir;
  const PointMap map = make_map_dir(dir / "map");
  const auto out = dir / "map.pcd";
  const ToolRun run = run_export("--map " + quoted(dir / "map") + " --format pcd --out " + quoted(out));
  ASSERT_EQ(run.exit_code, 0) << run.out;
  EXPECT_NE(run.out.find(std::to_string(map.num_points()) + " points"), std::string::npos) << run.out;
  pcl::PointCloud<pcl::PointXYZ> cloud;
  ASSERT_EQ(pcl::io::loadPCDFile(out.string(), cloud), 0);
  EXPECT_EQ(cloud.size(), map.num_points());
  EXPECT_EQ(sorted_points(cloud), sorted_points(map));
  // Read-only: the map directory is as it was (the journal still holds its two records).
  EXPECT_EQ(test::record_offsets(dir / "map" / MapStorage::kJournalName).size(), 2u);
}

TEST(MapExport, SnapshotFileToPly) {
  TempDir dir;
  const SavedMap saved = saved_snapshot(dir, 3);
  const auto out = dir / "map.ply";
  const ToolRun run = run_export("--snapshot " + quoted(saved.snapshot) + " --format ply --out " + quoted(out));
  ASSERT_EQ(run.exit_code, 0) << run.out;
  pcl::PointCloud<pcl::PointXYZ> cloud;
  ASSERT_EQ(pcl::io::loadPLYFile(out.string(), cloud), 0);
  EXPECT_EQ(cloud.size(), saved.map.num_points());
  EXPECT_EQ(sorted_points(cloud), sorted_points(saved.map));
}

TEST(MapExport, DamagedSnapshotExportsItsGoodPartWithAWarning) {
  TempDir dir;
  const SavedMap saved = saved_snapshot(dir, 3, 5.0);
  const auto& snapshot = saved.snapshot;
  const auto offsets = test::record_offsets(snapshot);
  ASSERT_GE(offsets.size(), 3u);
  test::flip_byte(snapshot, offsets[1] + 20);
  const auto out = dir / "map.pcd";
  const ToolRun run = run_export("--snapshot " + quoted(snapshot) + " --format pcd --out " + quoted(out));
  ASSERT_EQ(run.exit_code, 0) << run.out;
  EXPECT_NE(run.out.find("warning"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("byte " + std::to_string(offsets[1])), std::string::npos) << run.out;
  pcl::PointCloud<pcl::PointXYZ> cloud;
  ASSERT_EQ(pcl::io::loadPCDFile(out.string(), cloud), 0);
  EXPECT_GT(cloud.size(), 0u);
  EXPECT_LT(cloud.size(), saved.map.num_points());
}

TEST(MapExport, BadArgumentsAndUnreadableMapsExitWithTwo) {
  TempDir dir;
  const auto out = quoted(dir / "x.pcd");
  std::ofstream(dir / "junk.snapshot") << "not a snapshot";
  const std::string cases[] = {
      "",                                                               // nothing given
      "--format pcd --out " + out,                                      // no input
      "--map a --snapshot b --format pcd --out " + out,                 // both inputs
      "--snapshot " + quoted(dir / "junk.snapshot") + " --format xyz --out " + out,  // bad format
      "--snapshot " + quoted(dir / "junk.snapshot") + " --format pcd",  // no output
      "--bogus",                                                        // unknown option
      "--snapshot " + quoted(dir / "absent.snapshot") + " --format pcd --out " + out,
      "--snapshot " + quoted(dir / "junk.snapshot") + " --format pcd --out " + out,
      "--map " + quoted(dir / "absent") + " --format pcd --out " + out,
      "--map " + quoted(dir.path()) + " --format pcd --out " + out,  // a directory without a map
      "--snapshot " + quoted(dir / "junk.snapshot") + " --format ply --out " + out,  // disagrees with .pcd
      "--snapshot " + quoted(dir / "junk.snapshot") + " --out " + quoted(dir / "x.xyz"),  // no format at all
  };
  for (const std::string& args : cases) {
    const ToolRun run = run_export(args);
    EXPECT_EQ(run.exit_code, 2) << args << "\n" << run.out;
    EXPECT_NE(run.out.find("fuse-map-export: "), std::string::npos) << args << "\n" << run.out;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "x.pcd"));
  const ToolRun help = run_export("--help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("world"), std::string::npos) << "--help names the frame\n" << help.out;
}

// The format is the extension's, either case; the header names the frame the points are in.
TEST(MapExport, FormatFromTheExtensionAndTheFrameInTheHeader) {
  TempDir dir;
  const SavedMap saved = saved_snapshot(dir, 2);
  for (const char* name : {"a.pcd", "b.PLY"}) {
    const auto out = dir / name;
    const ToolRun run = run_export("--snapshot " + quoted(saved.snapshot) + " --out " + quoted(out));
    ASSERT_EQ(run.exit_code, 0) << name << "\n" << run.out;
    pcl::PointCloud<pcl::PointXYZ> cloud;
    const bool pcd = std::string(name).find(".pcd") != std::string::npos;
    ASSERT_EQ(pcd ? pcl::io::loadPCDFile(out.string(), cloud) : pcl::io::loadPLYFile(out.string(), cloud), 0) << name;
    EXPECT_EQ(sorted_points(cloud), sorted_points(saved.map)) << name;
    std::ifstream in(out, std::ios::binary);
    std::string header(400, '\0');
    in.read(header.data(), static_cast<std::streamsize>(header.size()));
    EXPECT_NE(header.find("frame: world"), std::string::npos) << name;
  }
}

// A folder that does not exist: the error names the path, and nothing is left behind.
TEST(MapExport, AnUnwritableOutputNamesThePath) {
  TempDir dir;
  const SavedMap saved = saved_snapshot(dir, 1);
  const auto out = dir / "missing-folder" / "map.pcd";
  const ToolRun run = run_export("--snapshot " + quoted(saved.snapshot) + " --out " + quoted(out));
  EXPECT_EQ(run.exit_code, 2) << run.out;
  EXPECT_NE(run.out.find((dir / "missing-folder").string()), std::string::npos) << run.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "missing-folder"));
}

}  // namespace
}  // namespace fuse

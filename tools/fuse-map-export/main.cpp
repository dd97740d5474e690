// fuse-map-export: writes the persistent map (a map directory's snapshot + journal, or one
// snapshot file) as a PCD or PLY point cloud (DESIGN §4). Never changes the map files: a map
// directory is opened read-only, so it can be exported while fuse-map runs.
#include <exception>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "arguments.hpp"
#include "cloud_writer.hpp"
#include "fuse/core/config.hpp"
#include "fuse/core/logging.hpp"
#include "fuse/map/map_server_core.hpp"
#include "fuse/map/map_storage.hpp"

namespace {

namespace fs = std::filesystem;
constexpr int kExitOk = 0;
constexpr int kExitBadInput = 2;

/// A failure that main reports as "fuse-map-export: <what>" with exit code 2.
class ExportError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

int export_points(const fuse::PointMap& map, const fuse::map_export::Arguments& args) {
  if (map.num_points() == 0) throw ExportError("the map has no points: nothing written");
  const std::size_t n = fuse::map_export::write_cloud(map, args.format, args.out);
  std::cout << n << " points written to " << args.out << "\n";
  return kExitOk;
}

int from_snapshot(const fuse::map_export::Arguments& args) {
  fuse::PointMap map;
  fuse::MapMeta meta;
  const fuse::LoadReport report = fuse::MapStorage::read_snapshot_file(args.snapshot_file, map, meta);
  for (const std::string& problem : report.problems) std::cerr << "fuse-map-export: warning: " << problem << "\n";
  if (!report.snapshot_ok) throw ExportError("cannot read snapshot " + args.snapshot_file);
  return export_points(map, args);
}

int from_directory(const fuse::map_export::Arguments& args) {
  const fs::path dir = args.map_dir;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw ExportError("no map directory " + args.map_dir);
  const fs::path snapshot = dir / fuse::MapStorage::kSnapshotName;
  if (!fs::exists(snapshot, ec) && !fs::exists(dir / fuse::MapStorage::kJournalName, ec)) {
    throw ExportError(args.map_dir + " holds no " + fuse::MapStorage::kSnapshotName + " or " +
                      fuse::MapStorage::kJournalName);
  }
  fuse::MapServerConfig config;
  if (!args.config_file.empty()) {
    fuse::ConfigNode root = fuse::ConfigNode::from_file(args.config_file);
    fuse::load_section(root, "map_server", config);
  } else {
    // Replay the journal as the server that wrote the snapshot did.
    fuse::MapMeta meta;
    if (fuse::MapStorage::read_snapshot_header(snapshot, meta)) config.policy.min_point_distance = meta.min_point_distance;
  }
  config.directory = args.map_dir;
  config.policy.mode = "mapping";
  // Problems in the files are logged as warnings by the core (the "map" logger, on stderr).
  const fuse::MapServerCore core(config, fuse::MapStorage::Access::kReadOnly);
  return export_points(core.map(), args);
}

}  // namespace

int main(int argc, char** argv) {
  fuse::map_export::Arguments args;
  if (const std::optional<int> code = fuse::map_export::parse_arguments(argc, argv, args)) return *code;
  try {
    fuse::set_log_level("warn");
    return args.snapshot_file.empty() ? from_directory(args) : from_snapshot(args);
  } catch (const std::exception& e) {
    std::cerr << "fuse-map-export: " << e.what() << "\n";
  } catch (...) {
    std::cerr << "fuse-map-export: unknown error\n";
  }
  return kExitBadInput;
}

// Command-line parsing of fuse-map-export: every argument is checked before any file is read.
#include "arguments.hpp"

#include <cctype>
#include <filesystem>

namespace fuse::map_export {
namespace {

/// The value after an option, or ArgumentError when the command line ends.
const std::string& value_of(const std::vector<std::string>& args, std::size_t& i) {
  if (i + 1 >= args.size()) throw ArgumentError(args[i] + " needs a value");
  return args[++i];
}

}  // namespace

std::optional<CloudFormat> format_of_extension(const std::string& file) {
  std::string ext = std::filesystem::path(file).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".pcd") return CloudFormat::kPcd;
  if (ext == ".ply") return CloudFormat::kPly;
  return std::nullopt;
}

std::string usage() {
  return "usage: fuse-map-export (--map DIR | --snapshot FILE) --out FILE.pcd|FILE.ply [--format pcd|ply]\n"
         "                       [--config FILE]\n"
         "  --map DIR        a map directory: its snapshot plus the journal replayed on top (read only)\n"
         "  --snapshot FILE  one snapshot file (as written by fuse-map's save)\n"
         "  --out FILE       the point cloud to write: x y z in metres in the map's `world` frame (the\n"
         "                   frame of fuse-state's poses, T_world_imu); the format is the extension's\n"
         "                   (.pcd binary PCD, .ply binary PLY), and the file's header names the frame\n"
         "  --format F       pcd or ply: only for a name without either extension (must agree otherwise)\n"
         "  --config FILE    YAML whose map_server section gives the policy and index the journal is\n"
         "                   replayed with (default: the snapshot's min_point_distance, default index)\n"
         "Prints the number of points written. Problems found in the map files are reported on stderr\n"
         "and their good part is exported.\n"
         "Exit codes: 0 success, 2 bad arguments, missing or unreadable map, empty map or write failure.\n";
}

Arguments parse_arguments(const std::vector<std::string>& args) {
  Arguments a;
  bool have_format = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "--help" || arg == "-h") {
      a.help = true;
    } else if (arg == "--map") {
      a.map_dir = value_of(args, i);
    } else if (arg == "--snapshot") {
      a.snapshot_file = value_of(args, i);
    } else if (arg == "--config") {
      a.config_file = value_of(args, i);
    } else if (arg == "--format") {
      const std::string& f = value_of(args, i);
      if (f == "pcd") {
        a.format = CloudFormat::kPcd;
      } else if (f == "ply") {
        a.format = CloudFormat::kPly;
      } else {
        throw ArgumentError("--format: '" + f + "' is not pcd or ply");
      }
      have_format = true;
    } else if (arg == "--out") {
      a.out = value_of(args, i);
    } else {
      throw ArgumentError("unknown argument '" + arg + "'");
    }
  }
  if (a.help) return a;
  if (a.map_dir.empty() == a.snapshot_file.empty()) throw ArgumentError("give exactly one of --map and --snapshot");
  if (a.out.empty()) throw ArgumentError("--out is required");
  const std::optional<CloudFormat> by_name = format_of_extension(a.out);
  if (by_name && have_format && *by_name != a.format) {
    throw ArgumentError("--format disagrees with the extension of --out '" + a.out + "'");
  }
  if (!by_name && !have_format) {
    throw ArgumentError("--out '" + a.out + "' has neither a .pcd nor a .ply extension: give --format");
  }
  if (by_name) a.format = *by_name;
  if (!a.config_file.empty() && a.map_dir.empty()) throw ArgumentError("--config only applies to --map");
  return a;
}

}  // namespace fuse::map_export

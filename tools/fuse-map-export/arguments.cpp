// Command-line parsing of fuse-map-export: every argument is checked before any file is read.
#include "arguments.hpp"

#include <cctype>
#include <filesystem>

#include "fuse/cli/cli.hpp"

namespace fuse::map_export {

std::optional<CloudFormat> format_of_extension(const std::string& file) {
  std::string ext = std::filesystem::path(file).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".pcd") return CloudFormat::kPcd;
  if (ext == ".ply") return CloudFormat::kPly;
  return std::nullopt;
}

std::optional<int> parse_arguments(int argc, char** argv, Arguments& a) {
  const auto app = cli::make_app(
      "fuse-map-export",
      "Writes a FUSE-SLAM map as a point cloud: x y z in metres in the map's `world` frame (the frame of "
      "fuse-state's poses, T_world_imu), named in the file's header. Prints the number of points written; "
      "problems found in the map files are reported on stderr and their good part is exported.",
      "Exit codes: 0 success, 2 bad arguments, missing or unreadable map, empty map or write failure.");
  std::string format;
  app->add_option("--map", a.map_dir, "a map directory: its snapshot plus the journal replayed on top (read only)")
      ->type_name("DIR");
  app->add_option("--snapshot", a.snapshot_file, "one snapshot file (as written by fuse-map's save)")
      ->type_name("FILE");
  app->add_option("--out", a.out,
                  "the point cloud to write; the format is the extension's (.pcd binary PCD, .ply binary PLY)")
      ->type_name("FILE.pcd|FILE.ply")
      ->required();
  app->add_option("--format", format, "only for a name without either extension (must agree otherwise)")
      ->type_name("pcd|ply")
      ->check(CLI::IsMember({"pcd", "ply"}));
  app->add_option("--config", a.config_file,
                  "YAML whose map_server section gives the policy and index the journal is replayed with "
                  "(default: the snapshot's min_point_distance, default index)")
      ->type_name("FILE");
  if (const std::optional<int> code = cli::parse(*app, argc, argv)) return code;
  const bool have_format = !format.empty();
  if (have_format) a.format = format == "ply" ? CloudFormat::kPly : CloudFormat::kPcd;
  if (a.map_dir.empty() == a.snapshot_file.empty()) return cli::usage_error(*app, "give exactly one of --map and --snapshot");
  const std::optional<CloudFormat> by_name = format_of_extension(a.out);
  if (by_name && have_format && *by_name != a.format) {
    return cli::usage_error(*app, "--format disagrees with the extension of --out '" + a.out + "'");
  }
  if (!by_name && !have_format) {
    return cli::usage_error(*app, "--out '" + a.out + "' has neither a .pcd nor a .ply extension: give --format");
  }
  if (by_name) a.format = *by_name;
  if (!a.config_file.empty() && a.map_dir.empty()) return cli::usage_error(*app, "--config only applies to --map");
  return std::nullopt;
}

}  // namespace fuse::map_export

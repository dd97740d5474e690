// Command line of fuse-map-export.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "cloud_writer.hpp"

namespace fuse::map_export {


struct Arguments {
  std::string map_dir;        ///< --map: snapshot + journal of a map directory
  std::string snapshot_file;  ///< --snapshot: one snapshot file
  std::string config_file;    ///< --config: map server settings used to replay a journal
  CloudFormat format = CloudFormat::kPcd;
  std::string out;
};

/// Parses and checks argv into `a` (CLI11, the convention of every binary: fuse/cli/cli.hpp).
/// std::nullopt: go on; otherwise the exit code to end with (0 after --help / --version, 2 after
/// a usage error, printed naming the flag).
std::optional<int> parse_arguments(int argc, char** argv, Arguments& a);

/// The format a file name's extension names (.pcd, .ply, any case); unset for another.
std::optional<CloudFormat> format_of_extension(const std::string& file);


}  // namespace fuse::map_export

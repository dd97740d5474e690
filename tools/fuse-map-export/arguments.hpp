// Command line of fuse-map-export.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cloud_writer.hpp"

namespace fuse::map_export {

/// A command line that cannot be used; main prints it with the usage and exits with 2.
class ArgumentError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Arguments {
  std::string map_dir;        ///< --map: snapshot + journal of a map directory
  std::string snapshot_file;  ///< --snapshot: one snapshot file
  std::string config_file;    ///< --config: map server settings used to replay a journal
  CloudFormat format = CloudFormat::kPcd;
  std::string out;
  bool help = false;
};

/// Parses argv[1..]; throws ArgumentError naming the offending argument.
Arguments parse_arguments(const std::vector<std::string>& args);

/// The format a file name's extension names (.pcd, .ply, any case); unset for another.
std::optional<CloudFormat> format_of_extension(const std::string& file);

/// The --help text.
std::string usage();

}  // namespace fuse::map_export

// rosbag2 metadata.yaml (rosbag2_storage "BagMetadata", versions 1-9): the storage plugin, the
// relative file paths, and per topic its name, type, serialisation format and message count.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace fuse::rosbag {

struct Rosbag2TopicMetadata {
  std::string name, type, serialization_format;
  std::uint64_t message_count = 0;
};

struct Rosbag2Metadata {
  int version = 0;
  std::string storage_identifier;  ///< "sqlite3" or "mcap"
  std::vector<std::string> relative_file_paths;
  std::string compression_format, compression_mode;  ///< "" when not compressed
  std::uint64_t message_count = 0;
  std::uint64_t starting_time_ns = 0, duration_ns = 0;
  std::vector<Rosbag2TopicMetadata> topics;
};

/// Reads `dir`/metadata.yaml; a missing file or field, or a wrong type -> fuse::io::InputError.
Rosbag2Metadata read_rosbag2_metadata(const std::string& dir);

}  // namespace fuse::rosbag

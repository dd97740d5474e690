#include "fuse/rosbag/rosbag2_metadata.hpp"

#include <yaml-cpp/yaml.h>

#include <filesystem>

#include "fuse/io/sensor_source.hpp"

namespace fuse::rosbag {

using io::InputError;

namespace {

YAML::Node need(const YAML::Node& n, const char* key, const std::string& where) {
  const YAML::Node v = n[key];
  if (!v) throw InputError(where + ": missing '" + key + "'");
  return v;
}

template <typename T>
T as(const YAML::Node& n, const char* key, const std::string& where) {
  try {
    return need(n, key, where).as<T>();
  } catch (const YAML::Exception& e) {
    throw InputError(where + ": '" + key + "' has the wrong type (" + e.msg + ")");
  }
}

}  // namespace

Rosbag2Metadata read_rosbag2_metadata(const std::string& dir) {
  const std::string path = (std::filesystem::path(dir) / "metadata.yaml").string();
  if (!std::filesystem::exists(path)) throw InputError(dir + ": no metadata.yaml (not a rosbag2 directory)");
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw InputError(path + ": not valid YAML: " + e.msg);
  }
  const std::string where = path + ": rosbag2_bagfile_information";
  const YAML::Node info = root["rosbag2_bagfile_information"];
  if (!info || !info.IsMap()) throw InputError(path + ": missing 'rosbag2_bagfile_information'");
  Rosbag2Metadata m;
  m.version = as<int>(info, "version", where);
  m.storage_identifier = as<std::string>(info, "storage_identifier", where);
  m.relative_file_paths = as<std::vector<std::string>>(info, "relative_file_paths", where);
  if (info["compression_format"]) m.compression_format = as<std::string>(info, "compression_format", where);
  if (info["compression_mode"]) m.compression_mode = as<std::string>(info, "compression_mode", where);
  m.message_count = as<std::uint64_t>(info, "message_count", where);
  m.starting_time_ns = as<std::uint64_t>(need(info, "starting_time", where), "nanoseconds_since_epoch", where + ".starting_time");
  m.duration_ns = as<std::uint64_t>(need(info, "duration", where), "nanoseconds", where + ".duration");
  const YAML::Node topics = need(info, "topics_with_message_count", where);
  if (!topics.IsSequence()) throw InputError(where + ": 'topics_with_message_count' is not a list");
  for (std::size_t i = 0; i < topics.size(); ++i) {
    const std::string w = where + ".topics_with_message_count[" + std::to_string(i) + "]";
    const YAML::Node tm = need(topics[i], "topic_metadata", w);
    Rosbag2TopicMetadata t;
    t.name = as<std::string>(tm, "name", w);
    t.type = as<std::string>(tm, "type", w);
    t.serialization_format = as<std::string>(tm, "serialization_format", w);
    t.message_count = as<std::uint64_t>(topics[i], "message_count", w);
    m.topics.push_back(std::move(t));
  }
  for (const auto& f : m.relative_file_paths) {
    if (f.empty() || std::filesystem::path(f).is_absolute() || f.find("..") != std::string::npos) {
      throw InputError(where + ": relative_file_paths entry '" + f + "' is not a plain relative path");
    }
  }
  return m;
}

}  // namespace fuse::rosbag

#include "fuse/rosbag/bag_reader.hpp"

#include <algorithm>
#include <filesystem>
#include <map>
#include <optional>

#include "fuse/io/sensor_source.hpp"
#include "fuse/rosbag/ros1_bag_reader.hpp"
#include "fuse/rosbag/rosbag2_metadata.hpp"
#include "fuse/rosbag/rosbag2_storage.hpp"

namespace fuse::rosbag {

using io::InputError;
namespace fs = std::filesystem;

namespace {

/// A ROS 1 bag: one topic per topic name (several connections of a topic are merged).
class Ros1Bag final : public BagReader {
 public:
  explicit Ros1Bag(const std::string& path) : bag_(path) {
    const auto counts = bag_.indexed_counts();
    for (const auto& entry : bag_.connections()) {
      const std::uint32_t id = entry.first;
      const Ros1Connection& c = entry.second;
      auto it = std::find_if(topics_.begin(), topics_.end(), [&](const BagTopic& t) { return t.name == c.topic; });
      if (it == topics_.end()) {
        topics_.push_back({c.topic, c.type, Serialization::kRos1, 0});
        it = topics_.end() - 1;
      } else if (it->type != c.type) {
        throw InputError(path + ": topic " + c.topic + " is recorded with two types (" + it->type + ", " + c.type + ")");
      }
      const auto n = counts.find(id);
      if (n != counts.end()) it->message_count += n->second;
      index_of_[id] = static_cast<std::size_t>(it - topics_.begin());
    }
  }
  const std::vector<BagTopic>& topics() const override { return topics_; }
  std::uint64_t start_time_ns() const override { return bag_.start_time_ns(); }
  std::uint64_t end_time_ns() const override { return bag_.end_time_ns(); }
  std::string describe() const override { return bag_.path() + " (ROS 1 bag v2.0)"; }
  void start(const std::vector<std::string>& names) override { bag_.start({names}); }
  bool next(BagMessage& out) override {
    if (!bag_.next(m_)) return false;
    out.topic = index_of_.at(m_.connection->id);
    out.time_ns = m_.time_ns;
    out.data = std::move(m_.data);
    return true;
  }

 private:
  Ros1BagReader bag_;
  Ros1Message m_;
  std::vector<BagTopic> topics_;
  std::map<std::uint32_t, std::size_t> index_of_;
};

/// A rosbag2 directory: metadata.yaml and its storage files, merged in time order.
class Rosbag2Bag final : public BagReader {
 public:
  explicit Rosbag2Bag(const std::string& dir) : dir_(dir), meta_(read_rosbag2_metadata(dir)) {
    const std::string where = dir + "/metadata.yaml";
    if (!meta_.compression_format.empty() || !meta_.compression_mode.empty()) {
      throw InputError(where + ": compressed rosbag2 (" + meta_.compression_format + ", mode " + meta_.compression_mode +
                       ") is not supported; decompress it first (ros2 bag convert)");
    }
    if (meta_.storage_identifier != "sqlite3" && meta_.storage_identifier != "mcap") {
      throw InputError(where + ": storage '" + meta_.storage_identifier + "' is not supported (sqlite3, mcap)");
    }
    for (const auto& t : meta_.topics) {
      Serialization s;
      if (t.serialization_format == "cdr") {
        s = Serialization::kCdr;
      } else if (t.serialization_format == "ros1") {
        s = Serialization::kRos1;
      } else {
        throw InputError(where + ": topic " + t.name + " has serialization format '" + t.serialization_format + "'");
      }
      topics_.push_back({t.name, t.type, s, t.message_count});
    }
    if (meta_.relative_file_paths.empty()) throw InputError(where + ": no storage files listed");
    for (const auto& rel : meta_.relative_file_paths) {
      const std::string path = (fs::path(dir) / rel).string();
      if (!fs::exists(path)) throw InputError(where + ": storage file " + rel + " is missing");
      Storage s;
      s.reader = meta_.storage_identifier == "sqlite3" ? open_sqlite3_storage(path) : open_mcap_storage(path);
      for (const auto& t : s.reader->topics()) {
        auto it = std::find_if(topics_.begin(), topics_.end(), [&](const BagTopic& b) { return b.name == t.name; });
        if (it == topics_.end()) throw InputError(path + ": topic " + t.name + " is not in metadata.yaml");
        if (ros1_type_name(it->type) != ros1_type_name(t.type)) {
          throw InputError(path + ": topic " + t.name + " has type " + t.type + ", metadata.yaml says " + it->type);
        }
        s.map.push_back(static_cast<std::size_t>(it - topics_.begin()));
      }
      storages_.push_back(std::move(s));
    }
  }
  const std::vector<BagTopic>& topics() const override { return topics_; }
  std::uint64_t start_time_ns() const override { return meta_.starting_time_ns; }
  std::uint64_t end_time_ns() const override { return meta_.starting_time_ns + meta_.duration_ns; }
  std::string describe() const override {
    return dir_ + " (rosbag2, " + meta_.storage_identifier + ", " + std::to_string(storages_.size()) + " file(s))";
  }
  void start(const std::vector<std::string>& names) override {
    for (auto& s : storages_) {
      s.reader->start(names);
      s.head.reset();
      s.done = false;
    }
  }
  bool next(BagMessage& out) override {
    Storage* best = nullptr;
    for (auto& s : storages_) {
      if (!s.head && !s.done) {
        BagMessage m;
        if (s.reader->next(m)) {
          m.topic = s.map.at(m.topic);
          s.head = std::move(m);
        } else {
          s.done = true;
        }
      }
      if (s.head && (best == nullptr || s.head->time_ns < best->head->time_ns)) best = &s;
    }
    if (best == nullptr) return false;
    out = std::move(*best->head);
    best->head.reset();
    return true;
  }

 private:
  struct Storage {
    std::unique_ptr<BagReader> reader;
    std::vector<std::size_t> map;  ///< storage topic index -> our topic index
    std::optional<BagMessage> head;
    bool done = false;
  };
  std::string dir_;
  Rosbag2Metadata meta_;
  std::vector<BagTopic> topics_;
  std::vector<Storage> storages_;
};

bool has_extension(const std::string& path, const char* ext) { return fs::path(path).extension() == ext; }

}  // namespace

std::string ros1_type_name(const std::string& type) {
  const auto p = type.find("/msg/");
  if (p == std::string::npos) return type;
  return type.substr(0, p) + "/" + type.substr(p + 5);
}

std::unique_ptr<BagReader> open_bag(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) return std::make_unique<Rosbag2Bag>(path);
  if (!fs::exists(path, ec)) throw InputError(path + ": no such file or directory");
  if (has_extension(path, ".bag")) return std::make_unique<Ros1Bag>(path);
  if (has_extension(path, ".db3")) return open_sqlite3_storage(path);
  if (has_extension(path, ".mcap")) return open_mcap_storage(path);
  throw InputError(path + ": unknown bag kind (expected a .bag file, a rosbag2 directory, or a .db3 / .mcap file)");
}

}  // namespace fuse::rosbag

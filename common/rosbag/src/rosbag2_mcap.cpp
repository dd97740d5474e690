// rosbag2 MCAP storage (rosbag2_storage_mcap): one MCAP channel per topic, the schema name is
// the message type ("sensor_msgs/msg/Imu", schema encoding "ros2msg"), message encoding "cdr".
// MCAP files with "ros1" message encoding are read too.
#include <algorithm>
#include <map>

#include "fuse/io/mcap_reader.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/rosbag/rosbag2_storage.hpp"

namespace fuse::rosbag {

using io::InputError;

namespace {

class McapStorage final : public BagReader {
 public:
  explicit McapStorage(const std::string& path) : path_(path), reader_(path) {
    for (const auto& [id, ch] : reader_.channels()) {
      BagTopic t;
      t.name = ch.topic;
      if (ch.message_encoding == "cdr") {
        t.serialization = Serialization::kCdr;
      } else if (ch.message_encoding == "ros1") {
        t.serialization = Serialization::kRos1;
      } else {
        // Not a ROS channel (e.g. JSON or protobuf): listed with its encoding, never decoded.
        skipped_[id] = ch.message_encoding;
        continue;
      }
      const auto s = reader_.schemas().find(ch.schema_id);
      if (s == reader_.schemas().end()) throw InputError(path + ": channel " + ch.topic + " has no schema (no type)");
      t.type = s->second.name;
      const auto existing = std::find_if(topics_.begin(), topics_.end(), [&](const BagTopic& b) { return b.name == t.name; });
      if (existing != topics_.end()) {
        if (existing->type != t.type) throw InputError(path + ": topic " + t.name + " has two types");
        index_of_[id] = static_cast<std::size_t>(existing - topics_.begin());
        continue;
      }
      index_of_[id] = topics_.size();
      topics_.push_back(std::move(t));
    }
    if (reader_.statistics()) {
      for (const auto& [id, n] : reader_.statistics()->channel_message_counts) {
        const auto it = index_of_.find(id);
        if (it != index_of_.end()) topics_[it->second].message_count += n;
      }
      start_ = reader_.statistics()->message_start_time;
      end_ = reader_.statistics()->message_end_time;
    }
  }

  const std::vector<BagTopic>& topics() const override { return topics_; }
  std::uint64_t start_time_ns() const override { return start_; }
  std::uint64_t end_time_ns() const override { return end_; }
  std::string describe() const override { return path_ + " (rosbag2 MCAP)"; }

  void start(const std::vector<std::string>& names) override {
    wanted_.clear();
    for (const auto& [id, index] : index_of_) {
      wanted_[id] = names.empty() || std::find(names.begin(), names.end(), topics_[index].name) != names.end();
    }
    reader_.start();
  }

  bool next(BagMessage& out) override {
    io::McapMessage m;
    while (reader_.next(m)) {
      const auto it = wanted_.find(m.header.channel_id);
      if (it == wanted_.end() || !it->second) continue;
      out.topic = index_of_.at(m.header.channel_id);
      out.time_ns = m.header.log_time;
      out.data = std::move(m.data);
      return true;
    }
    return false;
  }

 private:
  std::string path_;
  io::McapReader reader_;
  std::vector<BagTopic> topics_;
  std::map<std::uint16_t, std::size_t> index_of_;
  std::map<std::uint16_t, std::string> skipped_;
  std::map<std::uint16_t, bool> wanted_;
  std::uint64_t start_ = 0, end_ = 0;
};

}  // namespace

std::unique_ptr<BagReader> open_mcap_storage(const std::string& path) { return std::make_unique<McapStorage>(path); }

}  // namespace fuse::rosbag

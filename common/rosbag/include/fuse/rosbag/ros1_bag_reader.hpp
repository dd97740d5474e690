// Reader of ROS 1 bag files, format version 2.0 (ROS wiki "Bags/Format/2.0").
//
// A bag is the line "#ROSBAG V2.0\n" followed by records; each record is
//   uint32 header_len, header (fields: uint32 field_len, "name=" + binary value),
//   uint32 data_len, data.
// The header field "op" gives the record type: 0x03 bag header, 0x05 chunk (compression "none",
// "bz2" or "lz4" — roslz4 writes the LZ4 *frame* format), 0x07 connection, 0x02 message data,
// 0x04 index data (per chunk and connection), 0x06 chunk info (in the index section at the end).
//
// Opening the bag walks every top-level record once (record headers only, chunk data is skipped)
// and checks each length against the file size. Connections and chunk time ranges come from the
// index section; a bag without one (a recorder that did not close it) is read in salvage mode:
// each complete chunk is decompressed once at open to learn its connections and times, and the
// end of iteration raises InputError naming where the file is cut off.
//
// Iteration returns messages in receive-time order (ties: file order), loading a chunk only when
// the merge reaches its start time. Every loaded chunk is checked against its chunk info record:
// the number of messages per connection must match, or InputError names the chunk.
//
// Use (e.g. to read ouster_ros/PacketMsg from a bag):
//   fuse::rosbag::Ros1BagReader bag(path);
//   for (const auto& [id, c] : bag.connections()) { ... c.topic, c.type, c.md5sum ... }
//   bag.start({{"/os_node/lidar_packets"}});            // topics to read; empty: all
//   fuse::rosbag::Ros1Message m;
//   while (bag.next(m)) { m.connection->topic; m.time_ns; m.data; }  // data: ROS 1 serialisation
// Every malformed input raises fuse::io::InputError (never a crash or an unchecked allocation).
#pragma once

#include <cstdint>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <queue>
#include <string>
#include <vector>

namespace fuse::rosbag {

/// A connection record: one topic as published by one node, with its message type.
struct Ros1Connection {
  std::uint32_t id = 0;
  std::string topic;
  std::string type;                ///< e.g. "sensor_msgs/Imu"
  std::string md5sum;
  std::string message_definition;  ///< full text (with dependencies), as the recorder stored it
  std::string callerid;            ///< optional
  bool latching = false;           ///< optional ("latching=1")
};

/// One chunk: where it is, how it is compressed, and its index (times and counts per connection).
struct Ros1Chunk {
  std::uint64_t record_pos = 0;  ///< file offset of the chunk record
  std::uint64_t data_pos = 0;    ///< file offset of its data
  std::uint32_t data_len = 0;
  std::string compression;       ///< "none", "bz2" or "lz4"
  std::uint32_t uncompressed_size = 0;
  std::uint64_t start_time_ns = 0, end_time_ns = 0;
  std::map<std::uint32_t, std::uint32_t> counts;  ///< connection -> messages in this chunk
  bool has_info = false;                          ///< a chunk info record described it
};

struct Ros1Message {
  const Ros1Connection* connection = nullptr;
  std::uint64_t time_ns = 0;  ///< receive time (sec * 1e9 + nsec)
  std::vector<std::uint8_t> data;  ///< the serialised message (ROS 1 serialisation)
};

struct Ros1ReadOptions {
  std::vector<std::string> topics;  ///< topics to return; empty: every topic
};

class Ros1BagReader {
 public:
  /// Opens the bag and reads its structure; throws fuse::io::InputError on a malformed bag.
  explicit Ros1BagReader(const std::string& path);
  ~Ros1BagReader();
  Ros1BagReader(const Ros1BagReader&) = delete;
  Ros1BagReader& operator=(const Ros1BagReader&) = delete;

  const std::string& path() const { return path_; }
  const std::map<std::uint32_t, Ros1Connection>& connections() const { return connections_; }
  const std::vector<Ros1Chunk>& chunks() const { return chunks_; }
  /// Messages per connection as the index (chunk info records) declares them.
  std::map<std::uint32_t, std::uint64_t> indexed_counts() const;
  std::uint64_t message_count() const;
  std::uint64_t start_time_ns() const;  ///< earliest message time (0 when the bag is empty)
  std::uint64_t end_time_ns() const;
  /// True when the bag has no usable index section (read in salvage mode).
  bool salvage_mode() const { return salvage_; }
  const std::string& salvage_error() const { return salvage_error_; }

  void start(const Ros1ReadOptions& options = {});
  /// Next message in time order; false at the end (salvage mode: InputError at the end instead).
  bool next(Ros1Message& out);
  /// Chunks decompressed since start().
  std::size_t chunks_loaded() const { return chunks_loaded_; }

 private:
  struct Loaded;
  struct Pending {
    std::uint64_t time_ns;
    std::uint64_t order;  ///< chunk index << 32 | message index: file order for ties
    std::shared_ptr<Loaded> chunk;
    std::size_t index;
    bool operator>(const Pending& o) const {
      return time_ns != o.time_ns ? time_ns > o.time_ns : order > o.order;
    }
  };

  std::vector<std::uint8_t> read_at(std::uint64_t offset, std::uint64_t n, const std::string& what);
  void scan();
  void register_connection(Ros1Connection c, const std::string& where);
  std::vector<std::uint8_t> chunk_bytes(const Ros1Chunk& chunk);
  std::shared_ptr<Loaded> load(std::size_t chunk_index, bool check_counts);

  std::string path_;
  std::ifstream in_;
  std::uint64_t size_ = 0;
  std::uint64_t index_pos_ = 0;
  std::map<std::uint32_t, Ros1Connection> connections_;
  std::vector<Ros1Chunk> chunks_;
  bool salvage_ = false;
  std::string salvage_error_;

  // Iteration.
  std::vector<std::string> wanted_topics_;  ///< empty: all
  std::vector<std::size_t> order_;  ///< chunk indexes by start time
  std::size_t next_chunk_ = 0;
  std::priority_queue<Pending, std::vector<Pending>, std::greater<Pending>> heap_;
  std::size_t chunks_loaded_ = 0;
};

}  // namespace fuse::rosbag

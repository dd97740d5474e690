#include "fuse/rosbag/ros1_bag_reader.hpp"

#include <algorithm>
#include <cstring>
#include <limits>

#include "fuse/core/logging.hpp"
#include "fuse/io/byte_io.hpp"
#include "fuse/io/compression.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/rosbag/bz2.hpp"

namespace fuse::rosbag {

using io::InputError;

namespace {

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr std::size_t kMagicSize = sizeof(kMagic) - 1;
/// Record header sizes beyond this are treated as corruption (real headers are < 1 KiB).
constexpr std::uint32_t kMaxHeaderLen = 1u << 20;
/// Connection records carry the message definition; anything beyond this is corruption.
constexpr std::uint32_t kMaxConnectionDataLen = 16u << 20;

// Record opcodes (Bags/Format/2.0, "Records").
enum Op : std::uint8_t {
  kMessageData = 0x02,
  kBagHeader = 0x03,
  kIndexData = 0x04,
  kChunk = 0x05,
  kChunkInfo = 0x06,
  kConnection = 0x07,
};

/// A record header (or connection data): fields "name=value", value bytes kept as they are.
class Fields {
 public:
  Fields(const std::uint8_t* data, std::size_t size, std::string where) : where_(std::move(where)) {
    io::ByteReader r(data, size, where_);
    while (!r.done()) {
      const std::uint32_t len = r.u32();
      const auto* p = r.bytes(len, "header field");
      const auto* eq = static_cast<const std::uint8_t*>(std::memchr(p, '=', len));
      if (eq == nullptr) throw InputError(where_ + ": header field without '='");
      std::string name(reinterpret_cast<const char*>(p), static_cast<std::size_t>(eq - p));
      std::string value(reinterpret_cast<const char*>(eq + 1), static_cast<std::size_t>(p + len - eq - 1));
      fields_[std::move(name)] = std::move(value);  // a repeated field: the last one counts
    }
  }
  bool has(const std::string& name) const { return fields_.count(name) != 0; }
  const std::string& raw(const std::string& name) const {
    auto it = fields_.find(name);
    if (it == fields_.end()) throw InputError(where_ + ": missing header field '" + name + "'");
    return it->second;
  }
  template <typename T>
  T fixed(const std::string& name) const {
    const std::string& v = raw(name);
    if (v.size() != sizeof(T)) {
      throw InputError(where_ + ": header field '" + name + "' has " + std::to_string(v.size()) + " bytes, expected " +
                       std::to_string(sizeof(T)));
    }
    T out;
    std::memcpy(&out, v.data(), sizeof(T));
    return out;
  }
  /// ROS time: uint32 sec, uint32 nsec -> nanoseconds.
  std::uint64_t time(const std::string& name) const {
    const std::string& v = raw(name);
    if (v.size() != 8) throw InputError(where_ + ": header field '" + name + "' is not an 8-byte time");
    std::uint32_t sec, nsec;
    std::memcpy(&sec, v.data(), 4);
    std::memcpy(&nsec, v.data() + 4, 4);
    return std::uint64_t{sec} * 1000000000ull + nsec;
  }
  std::uint8_t op() const { return fixed<std::uint8_t>("op"); }

 private:
  std::string where_;
  std::map<std::string, std::string> fields_;
};

std::uint64_t read_time(io::ByteReader& r) {
  const std::uint32_t sec = r.u32();
  const std::uint32_t nsec = r.u32();
  return std::uint64_t{sec} * 1000000000ull + nsec;
}

Ros1Connection parse_connection(const Fields& header, const std::uint8_t* data, std::size_t size,
                                const std::string& where) {
  Ros1Connection c;
  c.id = header.fixed<std::uint32_t>("conn");
  c.topic = header.raw("topic");
  const Fields d(data, size, where + " data");
  c.type = d.raw("type");
  c.md5sum = d.raw("md5sum");
  c.message_definition = d.raw("message_definition");
  if (d.has("callerid")) c.callerid = d.raw("callerid");
  if (d.has("latching")) c.latching = d.raw("latching") == "1";
  if (c.topic.empty()) throw InputError(where + ": empty topic");
  if (c.type.empty()) throw InputError(where + ": empty message type");
  return c;
}

std::string at(const char* what, std::uint64_t pos) { return std::string(what) + " at offset " + std::to_string(pos); }

}  // namespace

/// A decompressed chunk's messages (sorted by time, then file order).
struct Ros1BagReader::Loaded {
  std::vector<std::uint8_t> bytes;
  struct Entry {
    std::uint64_t time_ns;
    std::uint32_t conn;
    std::size_t offset, size;
  };
  std::vector<Entry> entries;
};

Ros1BagReader::Ros1BagReader(const std::string& path) : path_(path), in_(path, std::ios::binary) {
  if (!in_) throw InputError(path + ": cannot open ROS bag file");
  in_.seekg(0, std::ios::end);
  size_ = static_cast<std::uint64_t>(in_.tellg());
  scan();
}

Ros1BagReader::~Ros1BagReader() = default;

std::vector<std::uint8_t> Ros1BagReader::read_at(std::uint64_t offset, std::uint64_t n, const std::string& what) {
  if (offset > size_ || n > size_ - offset) {
    throw InputError(path_ + ": " + what + " needs bytes " + std::to_string(offset) + ".." + std::to_string(offset + n) +
                     " but the file has " + std::to_string(size_));
  }
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(n));
  in_.clear();
  in_.seekg(static_cast<std::streamoff>(offset));
  in_.read(reinterpret_cast<char*>(buf.data()), static_cast<std::streamsize>(n));
  if (!in_) throw InputError(path_ + ": read error at offset " + std::to_string(offset) + " (" + what + ")");
  return buf;
}

void Ros1BagReader::register_connection(Ros1Connection c, const std::string& where) {
  auto it = connections_.find(c.id);
  if (it == connections_.end()) {
    connections_.emplace(c.id, std::move(c));
    return;
  }
  if (it->second.topic != c.topic || it->second.type != c.type) {
    throw InputError(path_ + ": " + where + ": connection " + std::to_string(c.id) + " redefined (" + c.topic + " " +
                     c.type + ", was " + it->second.topic + " " + it->second.type + ")");
  }
}

// Walks the top-level records: bag header, chunks (+ their index data records), then the index
// section (connections, chunk infos). Bags/Format/2.0 "Overview".
void Ros1BagReader::scan() {
  if (size_ < kMagicSize) throw InputError(path_ + ": not a ROS bag (file shorter than the version line)");
  const auto magic = read_at(0, kMagicSize, "version line");
  if (std::memcmp(magic.data(), kMagic, kMagicSize) != 0) {
    throw InputError(path_ + ": not a ROS bag v2.0 (the file does not start with \"#ROSBAG V2.0\")");
  }
  std::uint64_t pos = kMagicSize;
  bool have_header = false;
  std::uint32_t header_conn_count = 0, header_chunk_count = 0;
  std::uint32_t index_connections = 0;
  std::map<std::uint64_t, std::size_t> chunk_by_pos;
  std::vector<Ros1Chunk> infos;  // from chunk info records
  std::string cut;               // why the walk stopped early (salvage)

  while (pos < size_) {
    const std::string where = path_ + ": " + at("record", pos);
    // Record framing: header_len, header, data_len, data.
    if (size_ - pos < 4) {
      cut = where + ": file ends inside the record's header length";
      break;
    }
    const auto len_bytes = read_at(pos, 4, "record header length");
    std::uint32_t header_len;
    std::memcpy(&header_len, len_bytes.data(), 4);
    if (header_len > kMaxHeaderLen) throw InputError(where + ": implausible header length " + std::to_string(header_len));
    if (size_ - pos - 4 < std::uint64_t{header_len} + 4) {
      cut = where + ": file ends inside the record header";
      break;
    }
    const auto header_bytes = read_at(pos + 4, std::uint64_t{header_len} + 4, "record header");
    std::uint32_t data_len;
    std::memcpy(&data_len, header_bytes.data() + header_len, 4);
    const std::uint64_t data_pos = pos + 8 + header_len;
    if (size_ - data_pos < data_len) {
      cut = where + ": file ends inside the record data (declared " + std::to_string(data_len) + " bytes, " +
            std::to_string(size_ - data_pos) + " present)";
      break;
    }
    const Fields h(header_bytes.data(), header_len, where);
    const std::uint8_t op = h.op();
    if (!have_header && op != kBagHeader) throw InputError(where + ": the first record is not the bag header");
    switch (op) {
      case kBagHeader: {
        if (have_header) throw InputError(where + ": second bag header record");
        have_header = true;
        index_pos_ = h.fixed<std::uint64_t>("index_pos");
        header_conn_count = h.fixed<std::uint32_t>("conn_count");
        header_chunk_count = h.fixed<std::uint32_t>("chunk_count");
        break;
      }
      case kChunk: {
        Ros1Chunk c;
        c.record_pos = pos;
        c.data_pos = data_pos;
        c.data_len = data_len;
        c.compression = h.raw("compression");
        c.uncompressed_size = h.fixed<std::uint32_t>("size");
        if (c.compression != "none" && c.compression != "bz2" && c.compression != "lz4") {
          throw InputError(where + ": chunk compression '" + c.compression + "' is not supported (none, bz2, lz4)");
        }
        chunk_by_pos[pos] = chunks_.size();
        chunks_.push_back(std::move(c));
        break;
      }
      case kIndexData: {
        // Follows its chunk; gives times and a count per connection (used when no chunk info).
        if (chunks_.empty()) throw InputError(where + ": index data record before any chunk");
        if (h.fixed<std::uint32_t>("ver") != 1) throw InputError(where + ": unsupported index data version");
        const std::uint32_t conn = h.fixed<std::uint32_t>("conn");
        const std::uint32_t count = h.fixed<std::uint32_t>("count");
        if (std::uint64_t{count} * 12 != data_len) {
          throw InputError(where + ": index data count " + std::to_string(count) + " does not match its " +
                           std::to_string(data_len) + " data bytes");
        }
        Ros1Chunk& c = chunks_.back();
        const auto data = read_at(data_pos, data_len, "index data");
        io::ByteReader r(data.data(), data.size(), where);
        for (std::uint32_t i = 0; i < count; ++i) {
          const std::uint64_t t = read_time(r);
          const std::uint32_t offset = r.u32();
          if (offset >= c.uncompressed_size) throw InputError(where + ": index entry offset beyond the chunk");
          if (c.counts.empty() || t < c.start_time_ns) c.start_time_ns = t;
          c.end_time_ns = std::max(c.end_time_ns, t);
        }
        c.counts[conn] += count;
        break;
      }
      case kConnection: {
        if (data_len > kMaxConnectionDataLen) throw InputError(where + ": implausible connection data length");
        const auto data = read_at(data_pos, data_len, "connection data");
        register_connection(parse_connection(h, data.data(), data.size(), where), at("connection record", pos));
        ++index_connections;
        break;
      }
      case kChunkInfo: {
        if (h.fixed<std::uint32_t>("ver") != 1) throw InputError(where + ": unsupported chunk info version");
        Ros1Chunk info;
        info.record_pos = h.fixed<std::uint64_t>("chunk_pos");
        info.start_time_ns = h.time("start_time");
        info.end_time_ns = h.time("end_time");
        const std::uint32_t count = h.fixed<std::uint32_t>("count");
        if (std::uint64_t{count} * 8 != data_len) throw InputError(where + ": chunk info count does not match its data");
        const auto data = read_at(data_pos, data_len, "chunk info data");
        io::ByteReader r(data.data(), data.size(), where);
        for (std::uint32_t i = 0; i < count; ++i) {
          const std::uint32_t conn = r.u32();
          info.counts[conn] += r.u32();
        }
        if (info.end_time_ns < info.start_time_ns) throw InputError(where + ": chunk info ends before it starts");
        infos.push_back(std::move(info));
        break;
      }
      case kMessageData:
        throw InputError(where + ": message data record outside a chunk");
      default:
        throw InputError(where + ": unknown record op " + std::to_string(op));
    }
    pos = data_pos + data_len;
  }
  if (!have_header) throw InputError(path_ + ": " + (cut.empty() ? "no bag header record" : cut));

  const bool indexed = cut.empty() && index_pos_ >= kMagicSize && index_pos_ <= size_ &&
                       (!infos.empty() || header_chunk_count == 0);
  if (indexed) {
    if (index_connections != header_conn_count) {
      throw InputError(path_ + ": bag header declares " + std::to_string(header_conn_count) +
                       " connections, the index section has " + std::to_string(index_connections));
    }
    if (infos.size() != header_chunk_count || infos.size() != chunks_.size()) {
      throw InputError(path_ + ": bag header declares " + std::to_string(header_chunk_count) + " chunks, the file has " +
                       std::to_string(chunks_.size()) + " and the index " + std::to_string(infos.size()));
    }
    for (auto& info : infos) {
      auto it = chunk_by_pos.find(info.record_pos);
      if (it == chunk_by_pos.end()) {
        throw InputError(path_ + ": chunk info points to offset " + std::to_string(info.record_pos) +
                         ", where no chunk record starts");
      }
      Ros1Chunk& c = chunks_[it->second];
      if (c.has_info) throw InputError(path_ + ": two chunk info records for the chunk at " + std::to_string(c.record_pos));
      c.has_info = true;
      c.start_time_ns = info.start_time_ns;
      c.end_time_ns = info.end_time_ns;
      c.counts = std::move(info.counts);
    }
    for (const auto& c : chunks_) {
      for (const auto& [conn, n] : c.counts) {
        if (!connections_.count(conn)) {
          throw InputError(path_ + ": " + at("chunk", c.record_pos) + " indexes messages of undefined connection " +
                           std::to_string(conn));
        }
      }
    }
    return;
  }

  // Salvage: no index section (an unclosed bag) or a cut-off file. Keep the complete chunks,
  // reading each once to learn its connections and times.
  salvage_ = true;
  salvage_error_ = (cut.empty() ? path_ + ": the bag has no index section (not closed by its recorder)" : cut) +
                   "; read " + std::to_string(chunks_.size()) + " complete chunks (rosbag reindex can repair it)";
  logger("rosbag")->warn("salvage mode: {}", salvage_error_);
  for (std::size_t i = 0; i < chunks_.size(); ++i) {
    auto loaded = load(i, false);
    Ros1Chunk& c = chunks_[i];
    c.counts.clear();
    for (const auto& e : loaded->entries) ++c.counts[e.conn];
    if (!loaded->entries.empty()) {
      c.start_time_ns = loaded->entries.front().time_ns;
      c.end_time_ns = loaded->entries.back().time_ns;
    }
  }
}

std::vector<std::uint8_t> Ros1BagReader::chunk_bytes(const Ros1Chunk& c) {
  const std::string where = path_ + ": " + at("chunk", c.record_pos);
  auto raw = read_at(c.data_pos, c.data_len, "chunk data");
  if (c.compression == "none") {
    if (raw.size() != c.uncompressed_size) {
      throw InputError(where + ": uncompressed chunk has " + std::to_string(raw.size()) + " bytes, header says " +
                       std::to_string(c.uncompressed_size));
    }
    return raw;
  }
  if (c.compression == "bz2") return bz2_decompress(raw.data(), raw.size(), c.uncompressed_size, where);
  return io::decompress("lz4", raw.data(), raw.size(), c.uncompressed_size, where);  // LZ4 frame format
}

std::shared_ptr<Ros1BagReader::Loaded> Ros1BagReader::load(std::size_t chunk_index, bool check_counts) {
  const Ros1Chunk& c = chunks_[chunk_index];
  auto loaded = std::make_shared<Loaded>();
  loaded->bytes = chunk_bytes(c);
  ++chunks_loaded_;
  const std::string where = path_ + ": " + at("chunk", c.record_pos);
  std::map<std::uint32_t, std::uint32_t> counts;
  std::size_t pos = 0;
  const auto& b = loaded->bytes;
  while (pos < b.size()) {
    const std::string rec = where + ", " + at("record", pos) + " in the chunk";
    io::ByteReader r(b.data() + pos, b.size() - pos, rec);
    const std::uint32_t header_len = r.u32();
    const auto* header = r.bytes(header_len, "record header");
    const std::uint32_t data_len = r.u32();
    const std::size_t data_off = pos + 8 + header_len;
    r.bytes(data_len, "record data");
    const Fields h(header, header_len, rec);
    const std::uint8_t op = h.op();
    if (op == kConnection) {
      register_connection(parse_connection(h, b.data() + data_off, data_len, rec), rec);
    } else if (op == kMessageData) {
      const std::uint32_t conn = h.fixed<std::uint32_t>("conn");
      if (!connections_.count(conn)) {
        throw InputError(rec + ": message of connection " + std::to_string(conn) + ", which is not defined");
      }
      loaded->entries.push_back({h.time("time"), conn, data_off, data_len});
      ++counts[conn];
    } else {
      throw InputError(rec + ": unexpected record op " + std::to_string(op) + " inside a chunk");
    }
    pos = data_off + data_len;
  }
  if (check_counts && counts != c.counts) {
    std::string detail;
    for (const auto& [conn, n] : c.counts) {
      const auto it = counts.find(conn);
      const std::uint32_t got = it == counts.end() ? 0 : it->second;
      if (got != n) detail += " connection " + std::to_string(conn) + ": index " + std::to_string(n) + ", chunk " + std::to_string(got) + ";";
    }
    for (const auto& [conn, n] : counts) {
      if (!c.counts.count(conn)) detail += " connection " + std::to_string(conn) + ": not indexed, chunk " + std::to_string(n) + ";";
    }
    throw InputError(where + ": messages per connection differ from the index:" + detail);
  }
  std::stable_sort(loaded->entries.begin(), loaded->entries.end(),
                   [](const Loaded::Entry& a, const Loaded::Entry& b2) { return a.time_ns < b2.time_ns; });
  if (check_counts && !loaded->entries.empty() &&
      (loaded->entries.front().time_ns < c.start_time_ns || loaded->entries.back().time_ns > c.end_time_ns)) {
    throw InputError(where + ": message times lie outside the chunk's indexed time range");
  }
  return loaded;
}

std::map<std::uint32_t, std::uint64_t> Ros1BagReader::indexed_counts() const {
  std::map<std::uint32_t, std::uint64_t> out;
  for (const auto& c : chunks_) {
    for (const auto& [conn, n] : c.counts) out[conn] += n;
  }
  return out;
}

std::uint64_t Ros1BagReader::message_count() const {
  std::uint64_t n = 0;
  for (const auto& [conn, k] : indexed_counts()) n += k;
  return n;
}

std::uint64_t Ros1BagReader::start_time_ns() const {
  std::uint64_t t = std::numeric_limits<std::uint64_t>::max();
  for (const auto& c : chunks_) {
    if (!c.counts.empty()) t = std::min(t, c.start_time_ns);
  }
  return t == std::numeric_limits<std::uint64_t>::max() ? 0 : t;
}

std::uint64_t Ros1BagReader::end_time_ns() const {
  std::uint64_t t = 0;
  for (const auto& c : chunks_) {
    if (!c.counts.empty()) t = std::max(t, c.end_time_ns);
  }
  return t;
}

void Ros1BagReader::start(const Ros1ReadOptions& options) {
  wanted_topics_ = options.topics;
  heap_ = {};
  chunks_loaded_ = 0;
  next_chunk_ = 0;
  order_.clear();
  for (std::size_t i = 0; i < chunks_.size(); ++i) {
    bool any = false;
    for (const auto& [conn, n] : chunks_[i].counts) {
      const auto& topic = connections_.at(conn).topic;
      if (n > 0 && (wanted_topics_.empty() ||
                    std::find(wanted_topics_.begin(), wanted_topics_.end(), topic) != wanted_topics_.end())) {
        any = true;
      }
    }
    if (any) order_.push_back(i);
  }
  std::stable_sort(order_.begin(), order_.end(),
                   [this](std::size_t a, std::size_t b) { return chunks_[a].start_time_ns < chunks_[b].start_time_ns; });
}

bool Ros1BagReader::next(Ros1Message& out) {
  // Load every chunk that may hold a message earlier than the earliest one loaded.
  while (next_chunk_ < order_.size() &&
         (heap_.empty() || chunks_[order_[next_chunk_]].start_time_ns <= heap_.top().time_ns)) {
    const std::size_t ci = order_[next_chunk_++];
    auto loaded = load(ci, !salvage_);
    for (std::size_t i = 0; i < loaded->entries.size(); ++i) {
      const auto& e = loaded->entries[i];
      if (!wanted_topics_.empty() && std::find(wanted_topics_.begin(), wanted_topics_.end(),
                                               connections_.at(e.conn).topic) == wanted_topics_.end()) {
        continue;
      }
      heap_.push({e.time_ns, (std::uint64_t{ci} << 32) | i, loaded, i});
    }
  }
  if (heap_.empty()) {
    if (salvage_) throw InputError(salvage_error_);
    return false;
  }
  const Pending p = heap_.top();
  heap_.pop();
  const auto& e = p.chunk->entries[p.index];
  out.connection = &connections_.at(e.conn);
  out.time_ns = e.time_ns;
  out.data.assign(p.chunk->bytes.begin() + static_cast<std::ptrdiff_t>(e.offset),
                  p.chunk->bytes.begin() + static_cast<std::ptrdiff_t>(e.offset + e.size));
  return true;
}

}  // namespace fuse::rosbag

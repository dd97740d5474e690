// Test-only writer of ROS 1 bag v2.0 files (ROS wiki "Bags/Format/2.0"), to re-chunk real bags
// with another compression and to build malformed bags. Not part of the library: the library
// only reads bags.
#pragma once

#include <bzlib.h>
#include <lz4frame.h>

#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace fuse::rosbag::test {

struct WriterConnection {
  std::uint32_t id;
  std::string topic, type, md5sum, definition;
};

struct WriterMessage {
  std::uint32_t conn;
  std::uint64_t time_ns;
  std::vector<std::uint8_t> data;
};

class Bytes {
 public:
  void u32(std::uint32_t v) { raw(&v, 4); }
  void raw(const void* p, std::size_t n) {
    const auto* b = static_cast<const std::uint8_t*>(p);
    buf.insert(buf.end(), b, b + n);
  }
  void field(const std::string& name, const void* value, std::size_t n) {
    u32(static_cast<std::uint32_t>(name.size() + 1 + n));
    raw(name.data(), name.size());
    raw("=", 1);
    raw(value, n);
  }
  void field(const std::string& name, const std::string& v) { field(name, v.data(), v.size()); }
  template <typename T>
  void field_fixed(const std::string& name, T v) { field(name, &v, sizeof v); }
  void field_time(const std::string& name, std::uint64_t ns) {
    const std::uint32_t t[2] = {static_cast<std::uint32_t>(ns / 1000000000ull), static_cast<std::uint32_t>(ns % 1000000000ull)};
    field(name, t, 8);
  }
  /// header_len, header, data_len, data.
  void record(const Bytes& header, const std::vector<std::uint8_t>& data) {
    u32(static_cast<std::uint32_t>(header.buf.size()));
    raw(header.buf.data(), header.buf.size());
    u32(static_cast<std::uint32_t>(data.size()));
    raw(data.data(), data.size());
  }
  std::vector<std::uint8_t> buf;
};

inline std::vector<std::uint8_t> compress(const std::string& how, const std::vector<std::uint8_t>& in) {
  if (how == "none") return in;
  std::vector<std::uint8_t> out;
  if (how == "bz2") {
    unsigned n = static_cast<unsigned>(in.size() * 1.02 + 1024);
    out.resize(n);
    if (BZ2_bzBuffToBuffCompress(reinterpret_cast<char*>(out.data()), &n,
                                 const_cast<char*>(reinterpret_cast<const char*>(in.data())),
                                 static_cast<unsigned>(in.size()), 9, 0, 0) != BZ_OK) {
      throw std::runtime_error("bz2 compression failed");
    }
    out.resize(n);
    return out;
  }
  LZ4F_preferences_t prefs{};
  out.resize(LZ4F_compressFrameBound(in.size(), &prefs));
  const std::size_t n = LZ4F_compressFrame(out.data(), out.size(), in.data(), in.size(), &prefs);
  if (LZ4F_isError(n)) throw std::runtime_error("lz4 compression failed");
  out.resize(n);
  return out;
}

inline Bytes connection_record(const WriterConnection& c) {
  Bytes h, d;
  h.field_fixed<std::uint8_t>("op", 0x07);
  h.field_fixed<std::uint32_t>("conn", c.id);
  h.field("topic", c.topic);
  d.field("topic", c.topic);
  d.field("type", c.type);
  d.field("md5sum", c.md5sum);
  d.field("message_definition", c.definition);
  Bytes r;
  r.record(h, d.buf);
  return r;
}

/// A whole bag: messages grouped into chunks of `per_chunk` messages, compressed with `compression`.
inline std::vector<std::uint8_t> write_bag(const std::vector<WriterConnection>& conns,
                                           const std::vector<WriterMessage>& msgs, const std::string& compression,
                                           std::size_t per_chunk) {
  Bytes out;
  out.raw("#ROSBAG V2.0\n", 13);
  const std::size_t header_pos = out.buf.size();
  auto bag_header = [&](std::uint64_t index_pos, std::uint32_t chunks) {
    Bytes h;
    h.field_fixed<std::uint8_t>("op", 0x03);
    h.field_fixed<std::uint64_t>("index_pos", index_pos);
    h.field_fixed<std::uint32_t>("conn_count", static_cast<std::uint32_t>(conns.size()));
    h.field_fixed<std::uint32_t>("chunk_count", chunks);
    Bytes r;
    // Padded so that the record is 4096 bytes (the header is rewritten in place on close).
    r.record(h, std::vector<std::uint8_t>(4096 - 8 - h.buf.size(), ' '));
    return r.buf;
  };
  const auto placeholder = bag_header(0, 0);
  out.raw(placeholder.data(), placeholder.size());
  Bytes infos;
  std::uint32_t chunk_count = 0;
  for (std::size_t begin = 0; begin < msgs.size(); begin += per_chunk) {
    const std::size_t end = std::min(msgs.size(), begin + per_chunk);
    Bytes inner;
    std::map<std::uint32_t, std::vector<std::pair<std::uint64_t, std::uint32_t>>> index;
    std::map<std::uint32_t, bool> seen;
    std::uint64_t t0 = ~0ull, t1 = 0;
    for (std::size_t i = begin; i < end; ++i) {
      const auto& m = msgs[i];
      if (!seen[m.conn]) {
        seen[m.conn] = true;
        for (const auto& c : conns) {
          if (c.id == m.conn) {
            const auto r = connection_record(c);
            inner.raw(r.buf.data(), r.buf.size());
          }
        }
      }
      index[m.conn].push_back({m.time_ns, static_cast<std::uint32_t>(inner.buf.size())});
      Bytes h;
      h.field_fixed<std::uint8_t>("op", 0x02);
      h.field_fixed<std::uint32_t>("conn", m.conn);
      h.field_time("time", m.time_ns);
      inner.record(h, m.data);
      t0 = std::min(t0, m.time_ns);
      t1 = std::max(t1, m.time_ns);
    }
    const std::uint64_t chunk_pos = out.buf.size();
    Bytes ch;
    ch.field_fixed<std::uint8_t>("op", 0x05);
    ch.field("compression", compression);
    ch.field_fixed<std::uint32_t>("size", static_cast<std::uint32_t>(inner.buf.size()));
    out.record(ch, compress(compression, inner.buf));
    for (const auto& [conn, entries] : index) {
      Bytes ih, id;
      ih.field_fixed<std::uint8_t>("op", 0x04);
      ih.field_fixed<std::uint32_t>("ver", 1);
      ih.field_fixed<std::uint32_t>("conn", conn);
      ih.field_fixed<std::uint32_t>("count", static_cast<std::uint32_t>(entries.size()));
      for (const auto& [t, off] : entries) {
        id.u32(static_cast<std::uint32_t>(t / 1000000000ull));
        id.u32(static_cast<std::uint32_t>(t % 1000000000ull));
        id.u32(off);
      }
      out.record(ih, id.buf);
    }
    Bytes ih, id;
    ih.field_fixed<std::uint8_t>("op", 0x06);
    ih.field_fixed<std::uint32_t>("ver", 1);
    ih.field_fixed<std::uint64_t>("chunk_pos", chunk_pos);
    ih.field_time("start_time", t0);
    ih.field_time("end_time", t1);
    ih.field_fixed<std::uint32_t>("count", static_cast<std::uint32_t>(index.size()));
    for (const auto& [conn, entries] : index) {
      id.u32(conn);
      id.u32(static_cast<std::uint32_t>(entries.size()));
    }
    infos.record(ih, id.buf);
    ++chunk_count;
  }
  const std::uint64_t index_pos = out.buf.size();
  for (const auto& c : conns) {
    const auto r = connection_record(c);
    out.raw(r.buf.data(), r.buf.size());
  }
  out.raw(infos.buf.data(), infos.buf.size());
  const auto header = bag_header(index_pos, chunk_count);
  std::memcpy(out.buf.data() + header_pos, header.data(), header.size());
  return out.buf;
}

inline void write_file(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

}  // namespace fuse::rosbag::test

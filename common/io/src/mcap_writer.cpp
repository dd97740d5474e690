#include "fuse/io/mcap_writer.hpp"

#include <algorithm>
#include <stdexcept>

#include "fuse/core/logging.hpp"
#include "fuse/io/compression.hpp"

namespace fuse::io {

McapWriter::McapWriter(const std::string& path, const McapWriterOptions& options)
    : path_(path), options_(options), out_(path, std::ios::binary | std::ios::trunc) {
  if (!out_) throw std::runtime_error("cannot create MCAP file '" + path + "'");
  ByteWriter start;
  start.raw(mcap::kMagic, mcap::kMagicSize);
  mcap::write_header(start, {options_.profile, options_.library});
  emit(start);
}

McapWriter::~McapWriter() {
  try {
    close();
  } catch (const std::exception& e) {
    logger("io")->error("closing MCAP file '{}' failed: {}", path_, e.what());
  }
}

void McapWriter::emit(const ByteWriter& bytes) { emit(bytes.buffer().data(), bytes.size()); }

void McapWriter::emit(const std::uint8_t* data, std::size_t size) {
  out_.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!out_) throw std::runtime_error("write to MCAP file '" + path_ + "' failed");
  if (options_.write_crcs) data_crc_.update(data, size);
  offset_ += size;
}

std::uint16_t McapWriter::add_schema(const std::string& name, const std::string& encoding, const std::string& data) {
  mcap::Schema s;
  s.id = static_cast<std::uint16_t>(schemas_.size() + 1);  // id 0 means "no schema"
  s.name = name;
  s.encoding = encoding;
  s.data.assign(data.begin(), data.end());
  // Schema and Channel records go to the data section as they are defined (before any message
  // that needs them) and are repeated in the summary for indexed readers.
  ByteWriter w;
  mcap::write_schema(w, s);
  emit(w);
  schemas_.push_back(std::move(s));
  return schemas_.back().id;
}

std::uint16_t McapWriter::add_channel(std::uint16_t schema_id, const std::string& topic,
                                      const std::string& message_encoding, const mcap::StringMap& metadata) {
  if (schema_id > schemas_.size()) throw std::invalid_argument("add_channel: unknown schema id " + std::to_string(schema_id));
  mcap::Channel c;
  c.id = static_cast<std::uint16_t>(channels_.size());
  c.schema_id = schema_id;
  c.topic = topic;
  c.message_encoding = message_encoding;
  c.metadata = metadata;
  ByteWriter w;
  mcap::write_channel(w, c);
  emit(w);
  channels_.push_back(std::move(c));
  stats_.channel_message_counts[channels_.back().id] = 0;
  return channels_.back().id;
}

void McapWriter::write_message(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time,
                               std::uint64_t publish_time, const std::uint8_t* data, std::size_t size) {
  if (closed_) throw std::logic_error("write_message on a closed MCAP writer");
  if (channel_id >= channels_.size()) throw std::invalid_argument("write_message: unknown channel id " + std::to_string(channel_id));
  const mcap::MessageHeader h{channel_id, sequence, log_time, publish_time};
  stats_.message_start_time = have_message_ ? std::min(stats_.message_start_time, log_time) : log_time;
  stats_.message_end_time = have_message_ ? std::max(stats_.message_end_time, log_time) : log_time;
  have_message_ = true;
  ++stats_.message_count;
  ++stats_.channel_message_counts[channel_id];

  if (!options_.use_chunks) {
    ByteWriter w;
    mcap::write_message(w, h, data, size);
    emit(w);
    return;
  }
  const bool chunk_empty = chunk_index_entries_.empty();
  chunk_start_time_ = chunk_empty ? log_time : std::min(chunk_start_time_, log_time);
  chunk_end_time_ = chunk_empty ? log_time : std::max(chunk_end_time_, log_time);
  auto& index = chunk_index_entries_[channel_id];
  index.channel_id = channel_id;
  index.entries.emplace_back(log_time, chunk_records_.size());  // offset in the uncompressed records
  mcap::write_message(chunk_records_, h, data, size);
  if (chunk_records_.size() >= options_.chunk_size_bytes) flush_chunk();
}

void McapWriter::write_metadata(const std::string& name, const mcap::StringMap& metadata) {
  if (closed_) throw std::logic_error("write_metadata on a closed MCAP writer");
  ByteWriter w;
  mcap::write_metadata(w, {name, metadata});
  metadata_indexes_.push_back({offset_, w.size(), name});
  emit(w);
  ++stats_.metadata_count;
}

void McapWriter::flush_chunk() {
  if (chunk_index_entries_.empty()) return;
  const auto& records = chunk_records_.buffer();
  mcap::ChunkHeader h;
  h.message_start_time = chunk_start_time_;
  h.message_end_time = chunk_end_time_;
  h.uncompressed_size = records.size();
  h.uncompressed_crc = options_.write_crcs ? crc32(records.data(), records.size()) : 0;
  h.compression = compression_name(options_.compression);
  // Uncompressed records go to the file as they are; compressed ones through a reused buffer.
  const bool packed = options_.compression != Compression::kNone;
  if (packed) compress_into(options_.compression, records.data(), records.size(), compressed_);
  const std::uint8_t* stored = packed ? compressed_.data() : records.data();
  const std::size_t stored_size = packed ? compressed_.size() : records.size();

  mcap::ChunkIndex ci;
  ci.message_start_time = h.message_start_time;
  ci.message_end_time = h.message_end_time;
  ci.chunk_start_offset = offset_;
  ci.compression = h.compression;
  ci.compressed_size = stored_size;
  ci.uncompressed_size = h.uncompressed_size;
  {
    ByteWriter w;
    mcap::write_chunk_head(w, h, stored_size);
    ci.chunk_length = w.size() + stored_size;
    emit(w);
    emit(stored, stored_size);
  }
  // Message Index records follow their chunk, one per channel present in it.
  const std::uint64_t index_start = offset_;
  for (const auto& [channel, index] : chunk_index_entries_) {
    ByteWriter w;
    mcap::write_message_index(w, index);
    ci.message_index_offsets[channel] = offset_;
    emit(w);
  }
  ci.message_index_length = offset_ - index_start;
  chunk_indexes_.push_back(std::move(ci));
  ++stats_.chunk_count;
  chunk_records_.clear();
  chunk_index_entries_.clear();
}

void McapWriter::close() {
  if (closed_) return;
  closed_ = true;
  flush_chunk();
  ByteWriter w;
  mcap::write_data_end(w, {options_.write_crcs ? data_crc_.value() : 0u});
  emit(w);
  write_summary_and_footer();
  out_.close();
  if (!out_) throw std::runtime_error("closing MCAP file '" + path_ + "' failed");
}

void McapWriter::write_summary_and_footer() {
  ByteWriter s;  // summary + summary offsets + footer, built in memory for its CRC
  mcap::Footer footer;
  if (options_.write_summary) {
    const std::uint64_t base = offset_;
    std::vector<mcap::SummaryOffset> groups;
    // Records are grouped by opcode (spec: "Summary Section"); one SummaryOffset per group.
    auto group = [&](mcap::Op op, auto&& write_all) {
      const std::size_t begin = s.size();
      write_all();
      if (s.size() > begin) groups.push_back({static_cast<std::uint8_t>(op), base + begin, s.size() - begin});
    };
    stats_.schema_count = static_cast<std::uint16_t>(schemas_.size());
    stats_.channel_count = static_cast<std::uint32_t>(channels_.size());
    group(mcap::Op::kSchema, [&] { for (const auto& x : schemas_) mcap::write_schema(s, x); });
    group(mcap::Op::kChannel, [&] { for (const auto& x : channels_) mcap::write_channel(s, x); });
    group(mcap::Op::kStatistics, [&] { mcap::write_statistics(s, stats_); });
    group(mcap::Op::kChunkIndex, [&] { for (const auto& x : chunk_indexes_) mcap::write_chunk_index(s, x); });
    group(mcap::Op::kMetadataIndex, [&] { for (const auto& x : metadata_indexes_) mcap::write_metadata_index(s, x); });
    footer.summary_start = base;
    footer.summary_offset_start = base + s.size();
    for (const auto& g : groups) mcap::write_summary_offset(s, g);
  }
  mcap::write_footer(s, footer);
  // summary_crc covers the summary start up to and including footer.summary_offset_start.
  if (options_.write_summary && options_.write_crcs) {
    const std::size_t crc_end = s.size() - sizeof(std::uint32_t);
    footer.summary_crc = crc32(s.buffer().data(), crc_end);
    s.patch_u32(crc_end, footer.summary_crc);
  }
  s.raw(mcap::kMagic, mcap::kMagicSize);
  out_.write(reinterpret_cast<const char*>(s.buffer().data()), static_cast<std::streamsize>(s.size()));
  if (!out_) throw std::runtime_error("write to MCAP file '" + path_ + "' failed");
  offset_ += s.size();
}

}  // namespace fuse::io

#include "fuse/io/mcap_records.hpp"

namespace fuse::io::mcap {
namespace {

// Writes <opcode><uint64 length, written as 0>; end_record() patches the length afterwards.
std::size_t begin_record(ByteWriter& w, Op op) {
  w.u8(static_cast<std::uint8_t>(op));
  const std::size_t length_pos = w.size();
  w.u64(0);
  return length_pos;
}
void end_record(ByteWriter& w, std::size_t length_pos) {
  w.patch_u64(length_pos, w.size() - length_pos - sizeof(std::uint64_t));
}

// Map/Array: uint32 byte length, then the items (spec "Serialization").
std::size_t begin_map(ByteWriter& w) {
  const std::size_t pos = w.size();
  w.u32(0);
  return pos;
}
void end_map(ByteWriter& w, std::size_t pos) {
  w.patch_u32(pos, static_cast<std::uint32_t>(w.size() - pos - sizeof(std::uint32_t)));
}

void write_string_map(ByteWriter& w, const StringMap& m) {
  const std::size_t pos = begin_map(w);
  for (const auto& [k, v] : m) {
    w.string(k);
    w.string(v);
  }
  end_map(w, pos);
}
void write_u16_u64_map(ByteWriter& w, const std::map<std::uint16_t, std::uint64_t>& m) {
  const std::size_t pos = begin_map(w);
  for (const auto& [k, v] : m) {
    w.u16(k);
    w.u64(v);
  }
  end_map(w, pos);
}

StringMap parse_string_map(ByteReader& r, const char* field) {
  ByteReader m = r.sub(r.u32(), field);
  StringMap out;
  while (!m.done()) {
    std::string key = m.string("map key");
    out[key] = m.string("map value");
  }
  return out;
}
std::map<std::uint16_t, std::uint64_t> parse_u16_u64_map(ByteReader& r, const char* field) {
  ByteReader m = r.sub(r.u32(), field);
  std::map<std::uint16_t, std::uint64_t> out;
  while (!m.done()) {
    const std::uint16_t key = m.u16();
    out[key] = m.u64();
  }
  return out;
}

}  // namespace

const char* op_name(std::uint8_t op) {
  static const char* const kNames[] = {"unknown",      "Header",          "Footer",     "Schema",
                                       "Channel",      "Message",         "Chunk",      "MessageIndex",
                                       "ChunkIndex",   "Attachment",      "AttachmentIndex", "Statistics",
                                       "Metadata",     "MetadataIndex",   "SummaryOffset",   "DataEnd"};
  return op < sizeof(kNames) / sizeof(kNames[0]) ? kNames[op] : "unknown";
}

Header parse_header(ByteReader& r) {
  Header v;
  v.profile = r.string("profile");
  v.library = r.string("library");
  return v;
}

Footer parse_footer(ByteReader& r) {
  Footer v;
  v.summary_start = r.u64();
  v.summary_offset_start = r.u64();
  v.summary_crc = r.u32();
  return v;
}

Schema parse_schema(ByteReader& r) {
  Schema v;
  v.id = r.u16();
  v.name = r.string("schema name");
  v.encoding = r.string("schema encoding");
  const std::uint32_t n = r.u32();
  const std::uint8_t* p = r.bytes(n, "schema data");
  v.data.assign(p, p + n);
  return v;
}

Channel parse_channel(ByteReader& r) {
  Channel v;
  v.id = r.u16();
  v.schema_id = r.u16();
  v.topic = r.string("topic");
  v.message_encoding = r.string("message encoding");
  v.metadata = parse_string_map(r, "channel metadata");
  return v;
}

MessageHeader parse_message_header(ByteReader& r) {
  MessageHeader v;
  v.channel_id = r.u16();
  v.sequence = r.u32();
  v.log_time = r.u64();
  v.publish_time = r.u64();
  return v;
}

ChunkHeader parse_chunk_header(ByteReader& r) {
  ChunkHeader v;
  v.message_start_time = r.u64();
  v.message_end_time = r.u64();
  v.uncompressed_size = r.u64();
  v.uncompressed_crc = r.u32();
  v.compression = r.string("compression");
  v.records_size = r.u64();
  v.records_offset = r.position();
  if (v.records_size > r.remaining()) {
    r.fail("chunk records length " + std::to_string(v.records_size) + " exceeds the record (" +
           std::to_string(r.remaining()) + " bytes left)");
  }
  return v;
}

MessageIndex parse_message_index(ByteReader& r) {
  MessageIndex v;
  v.channel_id = r.u16();
  ByteReader a = r.sub(r.u32(), "message index entries");
  constexpr std::size_t kEntrySize = 16;  // Tuple<Timestamp, uint64>
  if (a.remaining() % kEntrySize != 0) a.fail("message index array length is not a multiple of 16");
  v.entries.reserve(a.remaining() / kEntrySize);
  while (!a.done()) {
    const std::uint64_t t = a.u64();
    v.entries.emplace_back(t, a.u64());
  }
  return v;
}

ChunkIndex parse_chunk_index(ByteReader& r) {
  ChunkIndex v;
  v.message_start_time = r.u64();
  v.message_end_time = r.u64();
  v.chunk_start_offset = r.u64();
  v.chunk_length = r.u64();
  v.message_index_offsets = parse_u16_u64_map(r, "message index offsets");
  v.message_index_length = r.u64();
  v.compression = r.string("compression");
  v.compressed_size = r.u64();
  v.uncompressed_size = r.u64();
  return v;
}

AttachmentIndex parse_attachment_index(ByteReader& r) {
  AttachmentIndex v;
  v.offset = r.u64();
  v.length = r.u64();
  v.log_time = r.u64();
  v.create_time = r.u64();
  v.data_size = r.u64();
  v.name = r.string("attachment name");
  v.media_type = r.string("media type");
  return v;
}

Statistics parse_statistics(ByteReader& r) {
  Statistics v;
  v.message_count = r.u64();
  v.schema_count = r.u16();
  v.channel_count = r.u32();
  v.attachment_count = r.u32();
  v.metadata_count = r.u32();
  v.chunk_count = r.u32();
  v.message_start_time = r.u64();
  v.message_end_time = r.u64();
  v.channel_message_counts = parse_u16_u64_map(r, "channel message counts");
  return v;
}

Metadata parse_metadata(ByteReader& r) {
  Metadata v;
  v.name = r.string("metadata name");
  v.metadata = parse_string_map(r, "metadata map");
  return v;
}

MetadataIndex parse_metadata_index(ByteReader& r) {
  MetadataIndex v;
  v.offset = r.u64();
  v.length = r.u64();
  v.name = r.string("metadata name");
  return v;
}

SummaryOffset parse_summary_offset(ByteReader& r) {
  SummaryOffset v;
  v.group_opcode = r.u8();
  v.group_start = r.u64();
  v.group_length = r.u64();
  return v;
}

DataEnd parse_data_end(ByteReader& r) { return DataEnd{r.u32()}; }

void write_header(ByteWriter& w, const Header& v) {
  const auto pos = begin_record(w, Op::kHeader);
  w.string(v.profile);
  w.string(v.library);
  end_record(w, pos);
}

void write_footer(ByteWriter& w, const Footer& v) {
  const auto pos = begin_record(w, Op::kFooter);
  w.u64(v.summary_start);
  w.u64(v.summary_offset_start);
  w.u32(v.summary_crc);
  end_record(w, pos);
}

void write_schema(ByteWriter& w, const Schema& v) {
  const auto pos = begin_record(w, Op::kSchema);
  w.u16(v.id);
  w.string(v.name);
  w.string(v.encoding);
  w.u32(static_cast<std::uint32_t>(v.data.size()));
  w.raw(v.data.data(), v.data.size());
  end_record(w, pos);
}

void write_channel(ByteWriter& w, const Channel& v) {
  const auto pos = begin_record(w, Op::kChannel);
  w.u16(v.id);
  w.u16(v.schema_id);
  w.string(v.topic);
  w.string(v.message_encoding);
  write_string_map(w, v.metadata);
  end_record(w, pos);
}

void write_message(ByteWriter& w, const MessageHeader& v, const std::uint8_t* data, std::size_t size) {
  const auto pos = begin_record(w, Op::kMessage);
  w.u16(v.channel_id);
  w.u32(v.sequence);
  w.u64(v.log_time);
  w.u64(v.publish_time);
  w.raw(data, size);
  end_record(w, pos);
}

void write_chunk_head(ByteWriter& w, const ChunkHeader& v, std::uint64_t records_size) {
  const auto pos = begin_record(w, Op::kChunk);
  w.u64(v.message_start_time);
  w.u64(v.message_end_time);
  w.u64(v.uncompressed_size);
  w.u32(v.uncompressed_crc);
  w.string(v.compression);
  w.u64(records_size);
  // The record's length counts the records that follow this head.
  w.patch_u64(pos, w.size() - pos - sizeof(std::uint64_t) + records_size);
}

void write_message_index(ByteWriter& w, const MessageIndex& v) {
  const auto pos = begin_record(w, Op::kMessageIndex);
  w.u16(v.channel_id);
  const auto array_pos = begin_map(w);
  for (const auto& [t, offset] : v.entries) {
    w.u64(t);
    w.u64(offset);
  }
  end_map(w, array_pos);
  end_record(w, pos);
}

void write_chunk_index(ByteWriter& w, const ChunkIndex& v) {
  const auto pos = begin_record(w, Op::kChunkIndex);
  w.u64(v.message_start_time);
  w.u64(v.message_end_time);
  w.u64(v.chunk_start_offset);
  w.u64(v.chunk_length);
  write_u16_u64_map(w, v.message_index_offsets);
  w.u64(v.message_index_length);
  w.string(v.compression);
  w.u64(v.compressed_size);
  w.u64(v.uncompressed_size);
  end_record(w, pos);
}

void write_statistics(ByteWriter& w, const Statistics& v) {
  const auto pos = begin_record(w, Op::kStatistics);
  w.u64(v.message_count);
  w.u16(v.schema_count);
  w.u32(v.channel_count);
  w.u32(v.attachment_count);
  w.u32(v.metadata_count);
  w.u32(v.chunk_count);
  w.u64(v.message_start_time);
  w.u64(v.message_end_time);
  write_u16_u64_map(w, v.channel_message_counts);
  end_record(w, pos);
}

void write_metadata(ByteWriter& w, const Metadata& v) {
  const auto pos = begin_record(w, Op::kMetadata);
  w.string(v.name);
  write_string_map(w, v.metadata);
  end_record(w, pos);
}

void write_metadata_index(ByteWriter& w, const MetadataIndex& v) {
  const auto pos = begin_record(w, Op::kMetadataIndex);
  w.u64(v.offset);
  w.u64(v.length);
  w.string(v.name);
  end_record(w, pos);
}

void write_summary_offset(ByteWriter& w, const SummaryOffset& v) {
  const auto pos = begin_record(w, Op::kSummaryOffset);
  w.u8(v.group_opcode);
  w.u64(v.group_start);
  w.u64(v.group_length);
  end_record(w, pos);
}

void write_data_end(ByteWriter& w, const DataEnd& v) {
  const auto pos = begin_record(w, Op::kDataEnd);
  w.u32(v.data_section_crc);
  end_record(w, pos);
}

}  // namespace fuse::io::mcap

// MCAP record types and their binary layout (MCAP specification, major version 0:
// https://mcap.dev/spec). Every record is <opcode:uint8><content length:uint64><content>;
// integers little-endian, String = uint32 length + UTF-8, Map/Array = uint32 byte length + items.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "fuse/io/byte_io.hpp"

namespace fuse::io::mcap {

/// File magic, at the start and at the end: 0x89 "MCAP" '0' (major version) "\r\n".
inline constexpr std::uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n'};
inline constexpr std::size_t kMagicSize = sizeof(kMagic);
/// Opcode byte + uint64 content length.
inline constexpr std::size_t kRecordPrefixSize = 9;
/// Footer content: summary_start, summary_offset_start (uint64) + summary_crc (uint32).
inline constexpr std::size_t kFooterContentSize = 20;

enum class Op : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};
const char* op_name(std::uint8_t op);

using StringMap = std::map<std::string, std::string>;

struct Header {
  std::string profile, library;
};
struct Footer {
  std::uint64_t summary_start = 0, summary_offset_start = 0;
  std::uint32_t summary_crc = 0;
};
struct Schema {
  std::uint16_t id = 0;
  std::string name, encoding;
  std::vector<std::uint8_t> data;
};
struct Channel {
  std::uint16_t id = 0, schema_id = 0;
  std::string topic, message_encoding;
  StringMap metadata;
};
/// Message header fields; the payload is kept separately (a view or a copy).
struct MessageHeader {
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0, publish_time = 0;
};
/// Chunk fields except the records bytes, plus where those bytes are in the record content.
struct ChunkHeader {
  std::uint64_t message_start_time = 0, message_end_time = 0, uncompressed_size = 0;
  std::uint32_t uncompressed_crc = 0;
  std::string compression;
  std::uint64_t records_size = 0;    ///< compressed size of `records`
  std::uint64_t records_offset = 0;  ///< offset of `records` within the record content
};
struct MessageIndex {
  std::uint16_t channel_id = 0;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> entries;  ///< (log_time, offset in chunk)
};
struct ChunkIndex {
  std::uint64_t message_start_time = 0, message_end_time = 0;
  std::uint64_t chunk_start_offset = 0, chunk_length = 0;
  std::map<std::uint16_t, std::uint64_t> message_index_offsets;
  std::uint64_t message_index_length = 0;
  std::string compression;
  std::uint64_t compressed_size = 0, uncompressed_size = 0;
};
struct AttachmentIndex {
  std::uint64_t offset = 0, length = 0, log_time = 0, create_time = 0, data_size = 0;
  std::string name, media_type;
};
struct Statistics {
  std::uint64_t message_count = 0;
  std::uint16_t schema_count = 0;
  std::uint32_t channel_count = 0, attachment_count = 0, metadata_count = 0, chunk_count = 0;
  std::uint64_t message_start_time = 0, message_end_time = 0;
  std::map<std::uint16_t, std::uint64_t> channel_message_counts;
};
struct Metadata {
  std::string name;
  StringMap metadata;
};
struct MetadataIndex {
  std::uint64_t offset = 0, length = 0;
  std::string name;
};
struct SummaryOffset {
  std::uint8_t group_opcode = 0;
  std::uint64_t group_start = 0, group_length = 0;
};
struct DataEnd {
  std::uint32_t data_section_crc = 0;
};

// Parsing: `r` spans exactly one record's content. Fields added by later spec revisions
// (trailing bytes) are ignored, as the spec asks; missing fields raise InputError.
Header parse_header(ByteReader& r);
Footer parse_footer(ByteReader& r);
Schema parse_schema(ByteReader& r);
Channel parse_channel(ByteReader& r);
MessageHeader parse_message_header(ByteReader& r);  ///< leaves `r` at the payload
ChunkHeader parse_chunk_header(ByteReader& r);      ///< leaves `r` at the records bytes
MessageIndex parse_message_index(ByteReader& r);
ChunkIndex parse_chunk_index(ByteReader& r);
AttachmentIndex parse_attachment_index(ByteReader& r);
Statistics parse_statistics(ByteReader& r);
Metadata parse_metadata(ByteReader& r);
MetadataIndex parse_metadata_index(ByteReader& r);
SummaryOffset parse_summary_offset(ByteReader& r);
DataEnd parse_data_end(ByteReader& r);

// Serialisation: each appends one complete record (opcode, length, content) to `w`.
void write_header(ByteWriter& w, const Header& v);
void write_footer(ByteWriter& w, const Footer& v);
void write_schema(ByteWriter& w, const Schema& v);
void write_channel(ByteWriter& w, const Channel& v);
void write_message(ByteWriter& w, const MessageHeader& v, const std::uint8_t* data, std::size_t size);
/// The Chunk record without its records: opcode, length (the records' records_size included) and
/// the header fields; the records_size bytes of records are to follow it in the file.
void write_chunk_head(ByteWriter& w, const ChunkHeader& v, std::uint64_t records_size);
void write_message_index(ByteWriter& w, const MessageIndex& v);
void write_chunk_index(ByteWriter& w, const ChunkIndex& v);
void write_statistics(ByteWriter& w, const Statistics& v);
void write_metadata(ByteWriter& w, const Metadata& v);
void write_metadata_index(ByteWriter& w, const MetadataIndex& v);
void write_summary_offset(ByteWriter& w, const SummaryOffset& v);
void write_data_end(ByteWriter& w, const DataEnd& v);

}  // namespace fuse::io::mcap

// MCAP writer (MCAP specification, major version 0): chunked data section with per-chunk
// MessageIndex records, DataEnd with the data-section CRC, and a summary section (Schema,
// Channel, Statistics, ChunkIndex, MetadataIndex, SummaryOffset) closed by the Footer.
#pragma once

#include <cstdint>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "fuse/io/crc32.hpp"
#include "fuse/io/mcap_records.hpp"
#include "fuse/io/recording.hpp"

namespace fuse::io {

struct McapWriterOptions {
  Compression compression = Compression::kZstd;
  std::size_t chunk_size_bytes = 4u << 20;  ///< close a chunk once its uncompressed records exceed this
  bool use_chunks = true;                   ///< false: messages go straight into the data section
  bool write_summary = true;                ///< false: footer with summary_start = 0 (readers scan)
  bool write_crcs = true;                   ///< false: every CRC field is 0 ("not computed")
  std::string profile;                      ///< Header profile; empty = no well-known profile
  std::string library = "fuse-io";
};

class McapWriter {
 public:
  McapWriter(const std::string& path, const McapWriterOptions& options = {});
  ~McapWriter();  ///< closes the file if close() was not called (errors are logged)
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  /// Registers a schema; returns its id (>= 1, as the spec requires).
  std::uint16_t add_schema(const std::string& name, const std::string& encoding, const std::string& data);
  /// Registers a channel on `schema_id` (0 = no schema); returns its id.
  std::uint16_t add_channel(std::uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                            const mcap::StringMap& metadata = {});
  /// Times in nanoseconds. `channel_id` must come from add_channel().
  void write_message(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time,
                     std::uint64_t publish_time, const std::uint8_t* data, std::size_t size);
  void write_metadata(const std::string& name, const mcap::StringMap& metadata);
  /// Flushes the open chunk, writes DataEnd, summary, footer and magic. Idempotent.
  void close();

 private:
  void emit(const ByteWriter& bytes);
  void emit(const std::uint8_t* data, std::size_t size);
  void flush_chunk();
  void write_summary_and_footer();

  std::string path_;
  McapWriterOptions options_;
  std::ofstream out_;
  bool closed_ = false;
  std::uint64_t offset_ = 0;  ///< bytes written so far
  Crc32 data_crc_;            ///< over every byte before the DataEnd record

  std::vector<mcap::Schema> schemas_;
  std::vector<mcap::Channel> channels_;
  mcap::Statistics stats_;
  bool have_message_ = false;

  // Open chunk: uncompressed records, time span and per-channel (log_time, offset) index.
  ByteWriter chunk_records_;
  std::vector<std::uint8_t> compressed_;  ///< a chunk's compressed records, the buffer reused from chunk to chunk
  std::uint64_t chunk_start_time_ = 0, chunk_end_time_ = 0;
  std::map<std::uint16_t, mcap::MessageIndex> chunk_index_entries_;

  std::vector<mcap::ChunkIndex> chunk_indexes_;
  std::vector<mcap::MetadataIndex> metadata_indexes_;
};

}  // namespace fuse::io

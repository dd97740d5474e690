// Generic MCAP reader. With a summary section it reads Schema/Channel/Statistics/ChunkIndex/
// MetadataIndex from it and loads only the chunks overlapping the requested time range;
// without one it falls back to a linear scan of the data section. Every length, offset and
// CRC (a CRC of 0 means "not computed") is checked: a malformed file raises InputError naming
// the record and its file offset, never reads out of bounds or allocates from an unchecked size.
#pragma once

#include <cstdint>
#include <deque>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <queue>
#include <string>
#include <tuple>
#include <vector>

#include "fuse/io/mcap_records.hpp"

namespace fuse::io {

struct McapMessage {
  const mcap::Channel* channel = nullptr;
  const mcap::Schema* schema = nullptr;  ///< nullptr when the channel has no schema (id 0)
  mcap::MessageHeader header;
  std::vector<std::uint8_t> data;
};

enum class ReadOrder { kLogTime, kFile };

struct McapReadOptions {
  std::uint64_t start_time = 0;  ///< log_time range, nanoseconds, both ends inclusive
  std::uint64_t end_time = std::numeric_limits<std::uint64_t>::max();
  ReadOrder order = ReadOrder::kLogTime;  ///< log time (ties: file order) or file order
};

class McapReader {
 public:
  /// Opens and checks magic, header and footer; reads the summary or scans the data section.
  explicit McapReader(const std::string& path);

  const mcap::Header& header() const { return header_; }
  bool has_summary() const { return indexed_; }  ///< true when messages are located via ChunkIndex
  const std::map<std::uint16_t, mcap::Schema>& schemas() const { return schemas_; }
  const std::map<std::uint16_t, mcap::Channel>& channels() const { return channels_; }
  /// The file's own Statistics record, when it has one.
  const std::optional<mcap::Statistics>& statistics() const { return statistics_; }
  const std::vector<mcap::Metadata>& metadata() const { return metadata_; }
  const std::vector<mcap::ChunkIndex>& chunk_indexes() const { return chunk_indexes_; }
  std::uint64_t file_size() const { return size_; }

  /// Starts (or restarts) iteration over the messages selected by `options`.
  void start(const McapReadOptions& options = {});
  /// Next selected message; false at the end.
  bool next(McapMessage& out);
  /// Chunks (or runs of un-chunked records) read from disk since start().
  std::size_t blocks_loaded() const { return blocks_loaded_; }

  /// Full check: linear pass over the data section verifying every record, chunk CRC and the
  /// data-section CRC, plus the summary CRC and the Statistics counts. Throws InputError.
  void verify();

 private:
  /// A unit the iterator loads at once: one Chunk record, or a run of top-level records.
  struct Block {
    std::uint64_t offset = 0, length = 0;  ///< file bytes: the chunk record, or the run of records
    bool chunk = false;
    std::uint64_t start_time = 0, end_time = 0;
    bool has_messages = false;
  };
  struct Loaded {
    const Block* block = nullptr;
    std::vector<McapMessage> messages;
    std::size_t next = 0;
  };
  /// Totals seen by a linear scan (to compare with the Statistics record).
  struct ScanTotals {
    std::uint64_t messages = 0;
    std::map<std::uint16_t, std::uint64_t> per_channel;
    std::uint32_t chunks = 0;
  };

  std::vector<std::uint8_t> read_at(std::uint64_t offset, std::uint64_t n, const std::string& what);
  void read_footer();
  void read_summary();
  /// Linear pass over the data section up to DataEnd; `collect` keeps blocks and metadata.
  std::vector<Block> scan_data_section(bool collect, ScanTotals& totals);
  std::uint64_t data_section_limit() const;
  void register_schema(mcap::Schema s, const std::string& where);
  void register_channel(mcap::Channel c, const std::string& where);
  using MessageSink = std::function<void(const mcap::MessageHeader&, const std::uint8_t*, std::size_t)>;
  /// Parses a buffer of whole records (chunk content or a top-level run): registers Schema and
  /// Channel records, passes each Message to `sink`, ignores other records.
  void parse_records(const std::uint8_t* data, std::size_t size, const std::string& where, const MessageSink& sink);
  /// Decompresses and CRC-checks one whole Chunk record (prefix included) read at `offset`.
  std::vector<std::uint8_t> chunk_records(const std::vector<std::uint8_t>& record, std::uint64_t offset,
                                          mcap::ChunkHeader& header);
  void load(const Block& block, Loaded& loaded);
  McapMessage take(Loaded& loaded);

  std::string path_;
  std::ifstream in_;
  std::uint64_t size_ = 0;
  std::uint64_t header_end_ = 0;  ///< first byte after the Header record
  std::uint64_t footer_pos_ = 0;
  mcap::Header header_;
  mcap::Footer footer_;
  bool indexed_ = false;

  std::map<std::uint16_t, mcap::Schema> schemas_;
  std::map<std::uint16_t, mcap::Channel> channels_;
  std::optional<mcap::Statistics> statistics_;
  std::vector<mcap::Metadata> metadata_;
  std::vector<mcap::ChunkIndex> chunk_indexes_;
  std::vector<Block> blocks_;

  // Iteration state.
  McapReadOptions options_;
  std::vector<const Block*> pending_;  ///< blocks still to load, in load order
  std::size_t pending_next_ = 0;
  std::deque<Loaded> loaded_;
  /// k-way merge heap over loaded blocks: (log_time, block offset, index into loaded_).
  using HeapItem = std::tuple<std::uint64_t, std::uint64_t, std::size_t>;
  std::priority_queue<HeapItem, std::vector<HeapItem>, std::greater<HeapItem>> heap_;
  std::size_t blocks_loaded_ = 0;
};

}  // namespace fuse::io

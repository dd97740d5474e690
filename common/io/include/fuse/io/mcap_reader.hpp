// Generic MCAP reader. With a summary section it reads Schema/Channel/Statistics/ChunkIndex/
// MetadataIndex from it and loads only the chunks overlapping the requested time range;
// without one it falls back to a linear scan of the data section. Every length, offset and
// CRC (a CRC of 0 means "not computed") is checked: a malformed file raises InputError naming
// the record and its file offset, never reads out of bounds or allocates from an unchecked size.
//
// Salvage mode: a file with a valid leading magic and Header but no valid Footer / trailing
// magic (a recorder that crashed, an interrupted copy), or whose summary cannot be read, is
// scanned linearly like a file without a summary. Every complete record before the first one
// that is cut off or damaged (e.g. a Chunk failing its CRC) is kept; iteration yields those
// messages and then raises InputError describing the truncation (file, byte offsets).
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
#include <utility>
#include <vector>

#include "fuse/io/crc32.hpp"
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
  /// Without a usable Footer/summary the file is opened in salvage mode (logged as a warning).
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
  /// True when the file is read in salvage mode (no valid Footer, or an unreadable summary).
  bool salvage_mode() const { return salvage_; }
  /// Salvage mode: what is damaged and where reading stops; the InputError next() raises at the end.
  const std::string& salvage_error() const { return salvage_error_; }

  /// Starts (or restarts) iteration over the messages selected by `options`.
  void start(const McapReadOptions& options = {});
  /// Next selected message; false at the end. In salvage mode the end is an InputError
  /// (salvage_error()) instead, raised after every recovered message has been returned.
  bool next(McapMessage& out);
  /// Chunks (or runs of un-chunked records) read from disk since start().
  std::size_t blocks_loaded() const { return blocks_loaded_; }

  /// Full check: linear pass over the data section verifying every record, chunk CRC and the
  /// data-section CRC, plus the summary CRC and the Statistics counts. Throws InputError
  /// (always in salvage mode: the file is incomplete).
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

  /// State of one linear pass over the data section.
  struct Scan {
    bool collect = false;  ///< keep blocks and metadata
    ScanTotals& totals;
    Crc32 crc;  ///< data-section CRC: every byte from the file start to the DataEnd record
    std::vector<Block> blocks;
  };

  std::vector<std::uint8_t> read_at(std::uint64_t offset, std::uint64_t n, const std::string& what);
  /// The same into `buf`, whose capacity is reused.
  void read_into(std::uint64_t offset, std::uint64_t n, const std::string& what, std::vector<std::uint8_t>& buf);
  void read_header();
  /// Reads the Footer; returns why the file has no usable one (then: salvage), or nullopt.
  std::optional<std::string> read_footer();
  void read_summary();
  /// Switches to salvage mode: forgets whatever a failed summary read registered.
  void enter_salvage(const std::string& reason);
  /// Linear pass over the data section up to DataEnd; `collect` keeps blocks and metadata.
  /// In salvage mode the first unreadable record ends the pass (recorded in salvage_error_).
  std::vector<Block> scan_data_section(bool collect, ScanTotals& totals);
  /// Reads the record at `pos`; returns the next record's offset, or nullopt after DataEnd.
  std::optional<std::uint64_t> scan_record(std::uint64_t pos, std::uint64_t limit, Scan& scan);
  /// Chunk or top-level Message record (whole `record`, prefix included) at `pos`.
  void scan_message_block(const std::vector<std::uint8_t>& record, std::uint64_t pos, Scan& scan);
  void check_data_end(const std::vector<std::uint8_t>& content, const std::string& where, const Scan& scan);
  void stream_crc(std::uint64_t offset, std::uint64_t n, const std::string& where, Scan& scan);
  /// Salvage mode: builds salvage_error_ once the pass stopped before record offset `pos`.
  void note_salvage_end(std::uint64_t pos, std::uint64_t recovered, const std::string& why);
  std::uint64_t data_section_limit() const;
  void register_schema(mcap::Schema s, const std::string& where);
  void register_channel(mcap::Channel c, const std::string& where);
  using MessageSink = std::function<void(const mcap::MessageHeader&, const std::uint8_t*, std::size_t)>;
  /// Parses a buffer of whole records (chunk content or a top-level run): registers Schema and
  /// Channel records, passes each Message to `sink`, ignores other records.
  void parse_records(const std::uint8_t* data, std::size_t size, const std::string& where, const MessageSink& sink);
  /// Decompresses and CRC-checks one whole Chunk record (prefix included) read at `offset`.
  /// Returns its records: inside `record` when the chunk is not compressed, else in
  /// records_buffer_ (valid until the next call).
  std::pair<const std::uint8_t*, std::size_t> chunk_records(const std::vector<std::uint8_t>& record, std::uint64_t offset,
                                                            mcap::ChunkHeader& header);
  void load(const Block& block, Loaded& loaded);
  McapMessage take(Loaded& loaded);
  /// End of iteration: false, or in salvage mode the InputError reporting the truncation.
  bool finish() const;

  std::string path_;
  std::ifstream in_;
  /// Reused from block to block: the record read (load()) and a chunk's decompressed records.
  std::vector<std::uint8_t> block_buffer_, records_buffer_;
  std::uint64_t size_ = 0;
  std::uint64_t header_end_ = 0;  ///< first byte after the Header record
  std::uint64_t footer_pos_ = 0;
  mcap::Header header_;
  mcap::Footer footer_;
  bool indexed_ = false;
  bool salvage_ = false;
  std::string salvage_reason_;  ///< why salvage mode: missing Footer, unreadable summary
  std::string salvage_error_;   ///< full report raised at the end of a salvage-mode read

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

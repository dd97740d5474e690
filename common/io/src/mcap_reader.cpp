#include "fuse/io/mcap_reader.hpp"

#include <algorithm>
#include <cstring>
#include <filesystem>

#include "fuse/core/logging.hpp"
#include "fuse/io/compression.hpp"
#include "fuse/io/crc32.hpp"

namespace fuse::io {
namespace {

using mcap::Op;
/// Piece size for streaming CRC over records the reader does not keep (e.g. attachments).
constexpr std::uint64_t kCrcPieceBytes = 1u << 20;
/// Smallest possible start of a file: magic, Header (two empty strings).
constexpr std::uint64_t kMinHeadSize = mcap::kMagicSize + mcap::kRecordPrefixSize + 2 * sizeof(std::uint32_t);

std::string at(std::uint64_t offset) { return " at offset " + std::to_string(offset); }

std::uint8_t opcode(const std::vector<std::uint8_t>& prefix) { return prefix[0]; }
std::uint64_t content_length(const std::vector<std::uint8_t>& prefix) {
  std::uint64_t n;
  std::memcpy(&n, prefix.data() + 1, sizeof n);
  return n;
}

}  // namespace

McapReader::McapReader(const std::string& path) : path_(path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw InputError("'" + path + "' is not a readable MCAP file");
  in_.open(path, std::ios::binary);
  if (!in_) throw InputError("cannot open MCAP file '" + path + "'");
  in_.seekg(0, std::ios::end);
  size_ = static_cast<std::uint64_t>(in_.tellg());
  if (size_ < kMinHeadSize) {
    throw InputError("'" + path + "' is not an MCAP file: " + std::to_string(size_) + " bytes, a magic and a Header need " +
                     std::to_string(kMinHeadSize));
  }
  read_header();
  // Without a valid Footer (spec: last record, then the trailing magic) the file was not closed:
  // it is salvaged by the linear scan. Damage found later, in the data section, stays an error.
  if (const auto missing = read_footer()) {
    enter_salvage("'" + path + "' is truncated at byte offset " + std::to_string(size_) + " (no footer: " + *missing + ")");
  } else if (footer_.summary_start != 0) {
    try {
      read_summary();
    } catch (const InputError& e) {
      enter_salvage("'" + path + "': summary section unreadable (" + e.what() + ")");
    }
  }
  if (!indexed_) {
    ScanTotals totals;
    blocks_ = scan_data_section(true, totals);
  }
}

void McapReader::read_header() {
  // Spec: the file starts with the magic, then a Header record.
  const auto magic = read_at(0, mcap::kMagicSize, "leading magic");
  if (std::memcmp(magic.data(), mcap::kMagic, mcap::kMagicSize) != 0) {
    throw InputError("'" + path_ + "' is not an MCAP file (bad leading magic)");
  }
  const auto prefix = read_at(mcap::kMagicSize, mcap::kRecordPrefixSize, "Header record");
  if (opcode(prefix) != static_cast<std::uint8_t>(Op::kHeader)) {
    throw InputError("'" + path_ + "': first record is " + mcap::op_name(opcode(prefix)) + ", expected Header");
  }
  const std::uint64_t header_len = content_length(prefix);
  const auto content = read_at(mcap::kMagicSize + mcap::kRecordPrefixSize, header_len, "Header record");
  ByteReader r(content.data(), content.size(), path_ + ": Header record" + at(mcap::kMagicSize));
  header_ = mcap::parse_header(r);
  header_end_ = mcap::kMagicSize + mcap::kRecordPrefixSize + header_len;
}

void McapReader::enter_salvage(const std::string& reason) {
  salvage_ = true;
  salvage_reason_ = reason;
  indexed_ = false;
  footer_ = {};
  schemas_.clear();
  channels_.clear();
  statistics_.reset();
  metadata_.clear();
  chunk_indexes_.clear();
  blocks_.clear();
  logger("io")->warn("{}; reading it in salvage mode: the messages of the complete records before the first "
                     "damaged one are read, then an error reports where reading stopped",
                     reason);
}

std::vector<std::uint8_t> McapReader::read_at(std::uint64_t offset, std::uint64_t n, const std::string& what) {
  std::vector<std::uint8_t> buf;
  read_into(offset, n, what, buf);
  return buf;
}

void McapReader::read_into(std::uint64_t offset, std::uint64_t n, const std::string& what, std::vector<std::uint8_t>& buf) {
  if (offset > size_ || n > size_ - offset) {
    throw InputError(path_ + ": " + what + at(offset) + " needs " + std::to_string(n) + " bytes but the file ends at " +
                     std::to_string(size_) + " (truncated or corrupt length)");
  }
  buf.resize(static_cast<std::size_t>(n));
  in_.clear();
  in_.seekg(static_cast<std::streamoff>(offset));
  in_.read(reinterpret_cast<char*>(buf.data()), static_cast<std::streamsize>(n));
  if (static_cast<std::uint64_t>(in_.gcount()) != n) throw InputError(path_ + ": read error in " + what + at(offset));
}

std::optional<std::string> McapReader::read_footer() {
  // Spec: the file ends with a Footer record (fixed 20-byte content) and the magic.
  constexpr std::uint64_t kTail = mcap::kRecordPrefixSize + mcap::kFooterContentSize + mcap::kMagicSize;
  if (size_ - header_end_ < kTail) return "no room for a Footer after the Header";
  const std::uint64_t magic_pos = size_ - mcap::kMagicSize;
  const auto magic = read_at(magic_pos, mcap::kMagicSize, "trailing magic");
  if (std::memcmp(magic.data(), mcap::kMagic, mcap::kMagicSize) != 0) {
    return "no trailing MCAP magic (file cut short, or still being written)";
  }
  footer_pos_ = magic_pos - mcap::kRecordPrefixSize - mcap::kFooterContentSize;
  const auto record = read_at(footer_pos_, mcap::kRecordPrefixSize + mcap::kFooterContentSize, "Footer record");
  if (opcode(record) != static_cast<std::uint8_t>(Op::kFooter) || content_length(record) != mcap::kFooterContentSize) {
    return "no valid Footer record" + at(footer_pos_) + " (found opcode " + std::to_string(opcode(record)) +
           ", length " + std::to_string(content_length(record)) + ")";
  }
  ByteReader r(record.data() + mcap::kRecordPrefixSize, mcap::kFooterContentSize, path_ + ": Footer" + at(footer_pos_));
  footer_ = mcap::parse_footer(r);
  return std::nullopt;
}

void McapReader::read_summary() {
  const std::uint64_t start = footer_.summary_start;
  const std::uint64_t offsets = footer_.summary_offset_start;
  const std::string where = path_ + ": summary section";
  if (start < header_end_ || start > footer_pos_) {
    throw InputError(where + ": Footer summary_start " + std::to_string(start) + " outside the file's data (" +
                     std::to_string(header_end_) + ".." + std::to_string(footer_pos_) + ")");
  }
  if (offsets != 0 && (offsets < start || offsets > footer_pos_)) {
    throw InputError(where + ": Footer summary_offset_start " + std::to_string(offsets) + " outside the summary");
  }
  const auto bytes = read_at(start, footer_pos_ - start, "summary section");
  if (footer_.summary_crc != 0) {
    // Spec (Footer): CRC of the summary start up to and including summary_offset_start.
    const auto footer = read_at(footer_pos_, mcap::kRecordPrefixSize + 2 * sizeof(std::uint64_t), "Footer record");
    Crc32 crc;
    crc.update(bytes.data(), bytes.size());
    crc.update(footer.data(), footer.size());
    if (crc.value() != footer_.summary_crc) {
      throw InputError(where + at(start) + ": CRC mismatch (Footer says " + std::to_string(footer_.summary_crc) +
                       ", computed " + std::to_string(crc.value()) + ")");
    }
  }
  std::vector<mcap::MetadataIndex> metadata_indexes;
  // Spec: the summary may repeat Channel records without their Schema records (those are then
  // only in the data section). Such channels are registered once the data section's are read.
  std::vector<std::pair<mcap::Channel, std::string>> channels_without_schema;
  ByteReader r(bytes.data(), bytes.size(), where + at(start));
  while (!r.done()) {
    const std::uint64_t pos = start + r.position();
    const std::uint8_t op = r.u8();
    ByteReader rec = r.sub(r.u64(), "record content").rest(where + ": " + mcap::op_name(op) + " record" + at(pos));
    switch (static_cast<Op>(op)) {
      case Op::kSchema: register_schema(mcap::parse_schema(rec), rec.context()); break;
      case Op::kChannel: {
        mcap::Channel c = mcap::parse_channel(rec);
        if (c.schema_id != 0 && schemas_.count(c.schema_id) == 0) {
          channels_without_schema.emplace_back(std::move(c), rec.context());
        } else {
          register_channel(std::move(c), rec.context());
        }
        break;
      }
      case Op::kStatistics:
        if (statistics_) rec.fail("a second Statistics record (the spec allows one)");
        statistics_ = mcap::parse_statistics(rec);
        break;
      case Op::kChunkIndex: chunk_indexes_.push_back(mcap::parse_chunk_index(rec)); break;
      case Op::kMetadataIndex: metadata_indexes.push_back(mcap::parse_metadata_index(rec)); break;
      case Op::kSummaryOffset: mcap::parse_summary_offset(rec); break;
      default: break;  // AttachmentIndex and records of later spec revisions: not needed
    }
  }
  for (const auto& ci : chunk_indexes_) {
    if (ci.chunk_start_offset < header_end_ || ci.chunk_length < mcap::kRecordPrefixSize ||
        ci.chunk_start_offset > start || ci.chunk_length > start - ci.chunk_start_offset) {
      throw InputError(where + ": ChunkIndex points outside the data section (chunk" + at(ci.chunk_start_offset) +
                       ", length " + std::to_string(ci.chunk_length) + ")");
    }
    if (ci.message_start_time > ci.message_end_time) {
      throw InputError(where + ": ChunkIndex for the chunk" + at(ci.chunk_start_offset) + " has start time after end time");
    }
  }
  // Messages are reachable through the index only when every chunk is indexed; a file whose
  // summary has no ChunkIndex (e.g. messages outside chunks) is read by a linear scan.
  indexed_ = !chunk_indexes_.empty() || (statistics_ && statistics_->message_count == 0);
  if (!indexed_) return;  // the scan registers the data section's schemas and channels too
  for (const auto& ci : chunk_indexes_) {
    blocks_.push_back({ci.chunk_start_offset, ci.chunk_length, true, ci.message_start_time, ci.message_end_time, true});
  }
  for (const auto& mi : metadata_indexes) {
    if (mi.offset < header_end_ || mi.length < mcap::kRecordPrefixSize || mi.offset > start || mi.length > start - mi.offset) {
      throw InputError(where + ": MetadataIndex '" + mi.name + "' points outside the data section" + at(mi.offset));
    }
    const auto record = read_at(mi.offset, mi.length, "Metadata record");
    if (opcode(record) != static_cast<std::uint8_t>(Op::kMetadata) || content_length(record) != mi.length - mcap::kRecordPrefixSize) {
      throw InputError(path_ + ": MetadataIndex '" + mi.name + "' does not point at a Metadata record" + at(mi.offset));
    }
    ByteReader mr(record.data() + mcap::kRecordPrefixSize, record.size() - mcap::kRecordPrefixSize,
                  path_ + ": Metadata record" + at(mi.offset));
    metadata_.push_back(mcap::parse_metadata(mr));
  }
  // Spec: the MetadataIndex records are optional. When the Statistics count more Metadata records
  // than the index locates, or neither says how many there are, they are read from the data section.
  const bool metadata_unindexed =
      statistics_ ? metadata_.size() < statistics_->metadata_count : metadata_indexes.empty();
  // One pass over the data section for what the summary lacks: it registers every Schema and
  // Channel record there and, collecting, every Metadata record (the index's blocks stay).
  if (metadata_unindexed || !channels_without_schema.empty()) {
    if (metadata_unindexed) metadata_.clear();
    ScanTotals totals;
    scan_data_section(metadata_unindexed, totals);
    for (auto& [channel, context] : channels_without_schema) register_channel(std::move(channel), context);
  }
}

std::uint64_t McapReader::data_section_limit() const {
  if (salvage_) return size_;  // no trustworthy Footer: the data may run to the end of the file
  return footer_.summary_start != 0 ? footer_.summary_start : footer_pos_;
}

std::vector<McapReader::Block> McapReader::scan_data_section(bool collect, ScanTotals& totals) {
  const std::uint64_t limit = data_section_limit();
  Scan scan{collect, totals, {}, {}};
  {
    const auto head = read_at(0, header_end_, "magic and Header");
    scan.crc.update(head.data(), head.size());
  }
  std::uint64_t pos = header_end_;
  for (;;) {
    const std::uint64_t recovered = totals.messages;
    std::optional<std::uint64_t> next;
    try {
      next = scan_record(pos, limit, scan);
    } catch (const InputError& e) {
      if (!salvage_) throw;
      // Salvage: a record cut off or damaged ends the data; everything before it is kept.
      totals.messages = recovered;
      note_salvage_end(pos, recovered, e.what());
      break;
    }
    if (!next) {
      if (salvage_) note_salvage_end(pos, totals.messages, "DataEnd record reached, the summary/Footer after it is missing or unreadable");
      break;
    }
    pos = *next;
  }
  return std::move(scan.blocks);
}

void McapReader::note_salvage_end(std::uint64_t pos, std::uint64_t recovered, const std::string& why) {
  salvage_error_ = salvage_reason_ + "; salvage mode recovered " + std::to_string(recovered) +
                   " messages from the complete records before byte offset " + std::to_string(pos) +
                   "; reading stopped there: " + why;
}

std::optional<std::uint64_t> McapReader::scan_record(std::uint64_t pos, std::uint64_t limit, Scan& scan) {
  if (limit - pos < mcap::kRecordPrefixSize) {
    throw InputError(path_ + ": data section ends" + at(pos) + " without a DataEnd record (file truncated?)");
  }
  const auto prefix = read_at(pos, mcap::kRecordPrefixSize, "record prefix");
  const std::uint8_t op = opcode(prefix);
  const std::uint64_t len = content_length(prefix);
  const std::string where = path_ + ": " + mcap::op_name(op) + " record" + at(pos);
  if (len > limit - pos - mcap::kRecordPrefixSize) {
    throw InputError(where + ": length " + std::to_string(len) + " runs past the end of the data section at " +
                     std::to_string(limit) + " (record cut off)");
  }
  const std::uint64_t content_pos = pos + mcap::kRecordPrefixSize;
  if (op == static_cast<std::uint8_t>(Op::kDataEnd)) {
    check_data_end(read_at(content_pos, len, "DataEnd record"), where, scan);
    return std::nullopt;
  }
  scan.crc.update(prefix.data(), prefix.size());
  const bool keep = op == static_cast<std::uint8_t>(Op::kChunk) || op == static_cast<std::uint8_t>(Op::kMessage) ||
                    op == static_cast<std::uint8_t>(Op::kSchema) || op == static_cast<std::uint8_t>(Op::kChannel) ||
                    op == static_cast<std::uint8_t>(Op::kMetadata);
  if (!keep) {  // not needed: only stream it through the CRC
    stream_crc(content_pos, len, where, scan);
    return content_pos + len;
  }
  const auto record = read_at(pos, mcap::kRecordPrefixSize + len, where);
  scan.crc.update(record.data() + mcap::kRecordPrefixSize, len);
  if (op == static_cast<std::uint8_t>(Op::kMetadata)) {
    ByteReader r(record.data() + mcap::kRecordPrefixSize, len, where);
    auto metadata = mcap::parse_metadata(r);
    if (scan.collect) metadata_.push_back(std::move(metadata));
  } else {
    scan_message_block(record, pos, scan);
  }
  return content_pos + len;
}

void McapReader::check_data_end(const std::vector<std::uint8_t>& content, const std::string& where, const Scan& scan) {
  ByteReader r(content.data(), content.size(), where);
  const auto data_end = mcap::parse_data_end(r);
  // Spec (DataEnd): CRC of every byte from the file start up to the DataEnd record; 0 = not computed.
  if (data_end.data_section_crc != 0 && data_end.data_section_crc != scan.crc.value()) {
    throw InputError(where + ": data section CRC mismatch (recorded " + std::to_string(data_end.data_section_crc) +
                     ", computed " + std::to_string(scan.crc.value()) + ")");
  }
}

void McapReader::stream_crc(std::uint64_t offset, std::uint64_t n, const std::string& where, Scan& scan) {
  for (std::uint64_t done = 0; done < n;) {
    const std::uint64_t piece_size = std::min(kCrcPieceBytes, n - done);
    const auto piece = read_at(offset + done, piece_size, where);
    scan.crc.update(piece.data(), piece.size());
    done += piece_size;
  }
}

void McapReader::scan_message_block(const std::vector<std::uint8_t>& record, std::uint64_t pos, Scan& scan) {
  const std::uint8_t op = opcode(record);
  const std::string where = path_ + ": " + mcap::op_name(op) + " record" + at(pos);
  Block block{pos, record.size(), false, 0, 0, false};
  std::uint64_t messages = 0;
  std::map<std::uint16_t, std::uint64_t> per_channel;
  auto track = [&](const mcap::MessageHeader& h, const std::uint8_t*, std::size_t) {
    block.start_time = block.has_messages ? std::min(block.start_time, h.log_time) : h.log_time;
    block.end_time = block.has_messages ? std::max(block.end_time, h.log_time) : h.log_time;
    block.has_messages = true;
    ++messages;
    ++per_channel[h.channel_id];
  };
  if (op == static_cast<std::uint8_t>(Op::kChunk)) {
    mcap::ChunkHeader h;
    const auto [records, n] = chunk_records(record, pos, h);  // throws on a CRC mismatch before any parsing
    parse_records(records, n, where, track);
    block.chunk = true;
    if (block.has_messages && (block.start_time < h.message_start_time || block.end_time > h.message_end_time)) {
      throw InputError(where + ": messages lie outside the chunk's declared time range");
    }
    ++scan.totals.chunks;
    if (scan.collect && block.has_messages) scan.blocks.push_back(block);
  } else {
    parse_records(record.data(), record.size(), path_ + ": top-level records", track);
    // Consecutive top-level messages form one run block.
    if (scan.collect && block.has_messages) {
      Block* last = scan.blocks.empty() ? nullptr : &scan.blocks.back();
      if (last && !last->chunk && last->offset + last->length == pos) {
        last->length += block.length;
        last->start_time = std::min(last->start_time, block.start_time);
        last->end_time = std::max(last->end_time, block.end_time);
      } else {
        scan.blocks.push_back(block);
      }
    }
  }
  // Counted only once the whole record has been read, so a damaged record adds nothing.
  scan.totals.messages += messages;
  for (const auto& [channel, count] : per_channel) scan.totals.per_channel[channel] += count;
}

void McapReader::register_schema(mcap::Schema s, const std::string& where) {
  if (s.id == 0) return;  // spec: a Schema with id 0 is invalid and ignored
  auto it = schemas_.find(s.id);
  if (it == schemas_.end()) {
    schemas_.emplace(s.id, std::move(s));
  } else if (it->second.name != s.name || it->second.encoding != s.encoding || it->second.data != s.data) {
    throw InputError(where + ": schema id " + std::to_string(s.id) + " redefined differently");
  }
}

void McapReader::register_channel(mcap::Channel c, const std::string& where) {
  if (c.schema_id != 0 && schemas_.count(c.schema_id) == 0) {
    throw InputError(where + ": channel '" + c.topic + "' refers to unknown schema id " + std::to_string(c.schema_id));
  }
  auto it = channels_.find(c.id);
  if (it == channels_.end()) {
    channels_.emplace(c.id, std::move(c));
  } else if (it->second.topic != c.topic || it->second.schema_id != c.schema_id ||
             it->second.message_encoding != c.message_encoding) {
    throw InputError(where + ": channel id " + std::to_string(c.id) + " redefined differently");
  }
}

void McapReader::parse_records(const std::uint8_t* data, std::size_t size, const std::string& where,
                               const MessageSink& sink) {
  ByteReader r(data, size, where);
  while (!r.done()) {
    const std::size_t pos = r.position();
    const std::uint8_t op = r.u8();
    ByteReader c = r.sub(r.u64(), "record content");
    switch (static_cast<Op>(op)) {
      case Op::kSchema: {
        ByteReader rec = c.rest(where + ": Schema record at byte " + std::to_string(pos));
        register_schema(mcap::parse_schema(rec), rec.context());
        break;
      }
      case Op::kChannel: {
        ByteReader rec = c.rest(where + ": Channel record at byte " + std::to_string(pos));
        register_channel(mcap::parse_channel(rec), rec.context());
        break;
      }
      case Op::kMessage: {
        const auto h = mcap::parse_message_header(c);
        if (channels_.count(h.channel_id) == 0) {
          throw InputError(where + ": Message record at byte " + std::to_string(pos) + " on unknown channel id " +
                           std::to_string(h.channel_id));
        }
        const std::size_t n = c.remaining();
        sink(h, c.bytes(n, "message data"), n);
        break;
      }
      default: break;  // MessageIndex, Attachment, ... and extension records are skipped
    }
  }
}

std::pair<const std::uint8_t*, std::size_t> McapReader::chunk_records(const std::vector<std::uint8_t>& record,
                                                                      std::uint64_t offset, mcap::ChunkHeader& h) {
  const std::string where = path_ + ": Chunk record" + at(offset);
  ByteReader r(record.data() + mcap::kRecordPrefixSize, record.size() - mcap::kRecordPrefixSize, where);
  h = mcap::parse_chunk_header(r);
  if (h.message_start_time > h.message_end_time) r.fail("message_start_time after message_end_time");
  const std::uint8_t* stored = record.data() + mcap::kRecordPrefixSize + h.records_offset;
  const auto stored_size = static_cast<std::size_t>(h.records_size);
  std::pair<const std::uint8_t*, std::size_t> records{stored, stored_size};
  if (!h.compression.empty() || stored_size != h.uncompressed_size) {  // a size mismatch: decompress_into names it
    decompress_into(h.compression, stored, stored_size, h.uncompressed_size, where, records_buffer_);
    records = {records_buffer_.data(), records_buffer_.size()};
  }
  if (h.uncompressed_crc != 0) {
    const std::uint32_t computed = crc32(records.first, records.second);
    if (computed != h.uncompressed_crc) {
      throw InputError(where + ": CRC mismatch of the uncompressed records (recorded " + std::to_string(h.uncompressed_crc) +
                       ", computed " + std::to_string(computed) + ")");
    }
  }
  return records;
}

void McapReader::start(const McapReadOptions& options) {
  options_ = options;
  pending_.clear();
  pending_next_ = 0;
  loaded_.clear();
  heap_ = {};
  blocks_loaded_ = 0;
  for (const auto& b : blocks_) {
    if (b.end_time >= options.start_time && b.start_time <= options.end_time) pending_.push_back(&b);
  }
  if (options.order == ReadOrder::kLogTime) {
    std::sort(pending_.begin(), pending_.end(), [](const Block* a, const Block* b) {
      return std::tie(a->start_time, a->offset) < std::tie(b->start_time, b->offset);
    });
  } else {
    std::sort(pending_.begin(), pending_.end(), [](const Block* a, const Block* b) { return a->offset < b->offset; });
  }
}

void McapReader::load(const Block& block, Loaded& loaded) {
  ++blocks_loaded_;
  loaded.block = &block;
  const std::string where = path_ + ": " + (block.chunk ? "Chunk record" : "records") + at(block.offset);
  read_into(block.offset, block.length, block.chunk ? "Chunk record" : "records", block_buffer_);
  const std::vector<std::uint8_t>& record = block_buffer_;
  auto keep = [&](const mcap::MessageHeader& h, const std::uint8_t* data, std::size_t n) {
    if (h.log_time < block.start_time || h.log_time > block.end_time) {
      throw InputError(where + ": message log_time " + std::to_string(h.log_time) + " outside the indexed range " +
                       std::to_string(block.start_time) + ".." + std::to_string(block.end_time));
    }
    if (h.log_time < options_.start_time || h.log_time > options_.end_time) return;
    McapMessage m;
    m.header = h;
    m.channel = &channels_.at(h.channel_id);
    const auto schema = schemas_.find(m.channel->schema_id);
    m.schema = schema == schemas_.end() ? nullptr : &schema->second;
    m.data.assign(data, data + n);
    loaded.messages.push_back(std::move(m));
  };
  if (block.chunk) {
    if (opcode(record) != static_cast<std::uint8_t>(Op::kChunk) ||
        content_length(record) != block.length - mcap::kRecordPrefixSize) {
      throw InputError(where + ": index points at a " + mcap::op_name(opcode(record)) + " record of length " +
                       std::to_string(content_length(record)) + ", expected a Chunk of length " +
                       std::to_string(block.length - mcap::kRecordPrefixSize));
    }
    mcap::ChunkHeader h;
    const auto [records, n] = chunk_records(record, block.offset, h);
    parse_records(records, n, where, keep);
  } else {
    parse_records(record.data(), record.size(), where, keep);
  }
  if (options_.order == ReadOrder::kLogTime) {
    std::stable_sort(loaded.messages.begin(), loaded.messages.end(),
                     [](const McapMessage& a, const McapMessage& b) { return a.header.log_time < b.header.log_time; });
  }
}

McapMessage McapReader::take(Loaded& loaded) {
  McapMessage m = std::move(loaded.messages[loaded.next++]);
  if (loaded.next == loaded.messages.size()) std::vector<McapMessage>().swap(loaded.messages);  // free the block
  return m;
}

bool McapReader::next(McapMessage& out) {
  if (options_.order == ReadOrder::kFile) {
    for (;;) {
      if (!loaded_.empty() && loaded_.back().next < loaded_.back().messages.size()) {
        out = take(loaded_.back());
        return true;
      }
      if (pending_next_ == pending_.size()) return finish();
      loaded_.clear();
      loaded_.emplace_back();
      load(*pending_[pending_next_++], loaded_.back());
    }
  }
  // Log-time order: a k-way merge. A block is loaded once the earliest message still queued is
  // not earlier than the block's start time, so overlapping chunks interleave correctly.
  while (pending_next_ < pending_.size() &&
         (heap_.empty() || pending_[pending_next_]->start_time <= std::get<0>(heap_.top()))) {
    const Block* b = pending_[pending_next_++];
    loaded_.emplace_back();
    load(*b, loaded_.back());
    if (!loaded_.back().messages.empty()) heap_.emplace(loaded_.back().messages[0].header.log_time, b->offset, loaded_.size() - 1);
  }
  if (heap_.empty()) return finish();
  const auto [t, offset, index] = heap_.top();
  heap_.pop();
  Loaded& l = loaded_[index];
  out = take(l);
  if (l.next < l.messages.size()) heap_.emplace(l.messages[l.next].header.log_time, offset, index);
  return true;
}

bool McapReader::finish() const {
  // Salvage mode: every recovered message has been returned; the end of the data is an error.
  if (salvage_) throw InputError(salvage_error_);
  return false;
}

void McapReader::verify() {
  if (salvage_) throw InputError(salvage_error_);
  ScanTotals totals;
  scan_data_section(false, totals);
  if (!statistics_) return;
  const auto& s = *statistics_;
  const std::string where = path_ + ": Statistics record";
  if (s.message_count != totals.messages) {
    throw InputError(where + " counts " + std::to_string(s.message_count) + " messages, the data section holds " +
                     std::to_string(totals.messages));
  }
  if (s.chunk_count != totals.chunks) {
    throw InputError(where + " counts " + std::to_string(s.chunk_count) + " chunks, the data section holds " +
                     std::to_string(totals.chunks));
  }
  for (const auto& [channel, count] : s.channel_message_counts) {
    const auto it = totals.per_channel.find(channel);
    const std::uint64_t found = it == totals.per_channel.end() ? 0 : it->second;
    if (found != count) {
      throw InputError(where + " counts " + std::to_string(count) + " messages on channel " + std::to_string(channel) +
                       ", the data section holds " + std::to_string(found));
    }
  }
}

}  // namespace fuse::io

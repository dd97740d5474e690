#include "rotating_writer.hpp"

#include <spdlog/fmt/fmt.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "fuse/core/logging.hpp"
#include "fuse/io/cdr_codec.hpp"
#include "fuse/io/recording.hpp"
#include "fuse_idl_text.hpp"

namespace fuse::record {
namespace {

/// Digits that make a double round-trip exactly through its decimal text.
constexpr int kRoundTripDigits = 17;
/// A file's chunks are at most this share of --max-bytes, so the size limit is kept closely.
constexpr std::uint64_t kChunksPerFile = 8;
constexpr std::size_t kMinChunkBytes = 64u << 10;

std::string exact(double v) { return fmt::format("{:.{}g}", v, kRoundTripDigits); }

}  // namespace

RotatingWriter::RotatingWriter(const RotationOptions& options, std::vector<const TopicType*> topics)
    : options_(options), topics_(std::move(topics)) {
  std::error_code ec;
  std::filesystem::create_directories(options_.dir, ec);
  if (ec) throw std::runtime_error("cannot create output directory '" + options_.dir + "': " + ec.message());
  open_next();
}

RotatingWriter::~RotatingWriter() {
  try {
    close();
  } catch (const std::exception& e) {
    logger("record")->error("closing {}: {}", files_.empty() ? "" : files_.back().path, e.what());
  }
}

void RotatingWriter::open_next() {
  FileSummary file;
  file.path = (std::filesystem::path(options_.dir) / fmt::format("{}_{:03d}.mcap", options_.prefix, files_.size())).string();
  io::McapWriterOptions o;
  o.compression = options_.compression;
  if (options_.max_bytes > 0) {
    o.chunk_size_bytes = std::clamp<std::size_t>(options_.max_bytes / kChunksPerFile, kMinChunkBytes, o.chunk_size_bytes);
  }
  writer_ = std::make_unique<io::McapWriter>(file.path, o);
  // One schema per type (the IDL text holds them all), one channel per topic.
  std::map<std::string, std::uint16_t> schemas;
  channels_.clear();
  for (const TopicType* t : topics_) {
    auto it = schemas.find(t->type_name);
    if (it == schemas.end()) {
      it = schemas.emplace(t->type_name, writer_->add_schema(t->type_name, io::kSchemaEncoding, fuse::msgs::kIdlText)).first;
    }
    channels_.push_back(writer_->add_channel(it->second, t->topic, io::kMessageEncoding));
  }
  sequences_.assign(topics_.size(), 0);
  extra_ids_.clear();
  for (const foxglove::Channel& c : options_.extra_channels) {
    const std::uint16_t schema = writer_->add_schema(c.schema_name, c.schema_encoding, c.schema);
    extra_ids_.push_back(writer_->add_channel(schema, c.topic, c.encoding));
  }
  extra_sequences_.assign(extra_ids_.size(), 0);
  latched_.resize(extra_ids_.size());
  latched_due_ = !files_.empty();
  if (options_.calibration) {
    const Eigen::Vector3d p = options_.calibration->translation();
    const Eigen::Quaterniond q(options_.calibration->rotation());
    writer_->write_metadata(io::kCalibrationMetadata, {{"tx", exact(p.x())},
                                                       {"ty", exact(p.y())},
                                                       {"tz", exact(p.z())},
                                                       {"qx", exact(q.x())},
                                                       {"qy", exact(q.y())},
                                                       {"qz", exact(q.z())},
                                                       {"qw", exact(q.w())}});
  }
  opened_ = std::chrono::steady_clock::now();
  files_.push_back(file);
  logger("record")->info("writing {}", file.path);
}

void RotatingWriter::close_current() {
  if (!writer_) return;
  writer_->close();
  writer_.reset();
  const auto& f = files_.back();
  logger("record")->info("closed {}: {} messages, {} bytes", f.path, f.messages, f.bytes);
}

void RotatingWriter::before_message(std::uint64_t log_time, std::size_t size) {
  if (!writer_) throw std::logic_error("write after close");
  const FileSummary& open = files_.back();
  if (options_.max_bytes > 0 && open.messages + open.extra_messages > 0 && open.bytes + size > options_.max_bytes) {
    close_current();
    open_next();
  }
  if (!latched_due_) return;
  latched_due_ = false;
  for (std::size_t i = 0; i < latched_.size(); ++i) {
    if (!latched_[i]) continue;
    const auto* bytes = reinterpret_cast<const std::uint8_t*>(latched_[i]->data());
    put(extra_ids_[i], extra_sequences_[i], log_time, bytes, latched_[i]->size(), true);
  }
}

void RotatingWriter::put(std::uint16_t channel, std::uint32_t& sequence, std::uint64_t log_time,
                         const std::uint8_t* data, std::size_t size, bool extra) {
  writer_->write_message(channel, sequence++, log_time, log_time, data, size);
  ++(extra ? files_.back().extra_messages : files_.back().messages);
  files_.back().bytes += size;
}

void RotatingWriter::write(std::size_t topic, std::uint64_t log_time, const std::uint8_t* data, std::size_t size) {
  before_message(log_time, size);
  put(channels_.at(topic), sequences_.at(topic), log_time, data, size, false);
}

void RotatingWriter::write_extra(std::size_t channel, std::uint64_t log_time, const std::string& payload) {
  before_message(log_time, payload.size());
  const auto* bytes = reinterpret_cast<const std::uint8_t*>(payload.data());
  put(extra_ids_.at(channel), extra_sequences_.at(channel), log_time, bytes, payload.size(), true);
  if (options_.extra_channels[channel].latched) latched_[channel] = payload;
}

void RotatingWriter::rotate_if_due(std::chrono::steady_clock::time_point now) {
  if (!writer_ || options_.max_seconds <= 0.0) return;
  if (std::chrono::duration<double>(now - opened_).count() < options_.max_seconds) return;
  close_current();
  open_next();
}

void RotatingWriter::close() { close_current(); }

}  // namespace fuse::record

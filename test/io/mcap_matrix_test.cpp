// MCAP files written by @mcap/core's McapWriter (interop/write_matrix.mjs: every writer option
// off on its own and in pairs, files without messages or metadata, small chunks; zstd and lz4
// chunks with every option on and with each option off) are read completely by our reader, in
// log-time and in file order, and verify; the messages per topic and the Metadata records are what
// the writer's manifest (FILE.json) says it wrote, and every Chunk is compressed as it says.
#include <gtest/gtest.h>
#include <json/json.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include "fuse/io/byte_io.hpp"
#include "fuse/io/mcap_reader.hpp"
#include "fuse/io/mcap_records.hpp"

namespace fuse::io {
namespace {

namespace fs = std::filesystem;

Json::Value manifest_of(const fs::path& mcap) {
  std::ifstream in(fs::path(mcap).replace_extension(".json"));
  Json::Value v;
  Json::CharReaderBuilder b;
  std::string errors;
  EXPECT_TRUE(Json::parseFromStream(b, in, &v, &errors)) << mcap << ": " << errors;
  return v;
}

std::map<std::string, std::uint64_t> read_counts(McapReader& reader, ReadOrder order) {
  McapReadOptions options;
  options.order = order;
  reader.start(options);
  std::map<std::string, std::uint64_t> counts;
  McapMessage m;
  std::uint64_t last = 0;
  while (reader.next(m)) {
    ++counts[m.channel->topic];
    if (order == ReadOrder::kLogTime) {
      EXPECT_GE(m.header.log_time, last) << "log-time order";
      last = m.header.log_time;
    }
  }
  return counts;
}

/// write_matrix.mjs writes 79 files: 53 with uncompressed chunks, 13 with zstd, 13 with lz4.
constexpr std::size_t kMatrixFiles = 79;

/// The .mcap files in $FUSE_MCAP_MATRIX_DIR (empty, with a failure, when it is not set).
std::vector<fs::path> matrix_files() {
  const char* dir = std::getenv("FUSE_MCAP_MATRIX_DIR");
  if (dir == nullptr) {
    ADD_FAILURE() << "FUSE_MCAP_MATRIX_DIR is not set";
    return {};
  }
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() == ".mcap") files.push_back(e.path());
  }
  EXPECT_GE(files.size(), kMatrixFiles) << "the writer's matrix is missing from " << dir;
  return files;
}

/// The compression field of every Chunk record in the data section, in file order: a walk over
/// the top-level records with our record parser, so it needs no summary and no index.
std::vector<std::string> chunk_compressions(const fs::path& mcap) {
  std::ifstream in(mcap, std::ios::binary);
  const std::vector<std::uint8_t> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  ByteReader file(bytes.data(), bytes.size(), mcap.string());
  file.bytes(mcap::kMagicSize, "leading magic");
  std::vector<std::string> compressions;
  for (;;) {
    const auto op = static_cast<mcap::Op>(file.u8());
    ByteReader content = file.sub(file.u64(), "record content");
    if (op == mcap::Op::kDataEnd) break;
    if (op == mcap::Op::kChunk) compressions.push_back(mcap::parse_chunk_header(content).compression);
  }
  return compressions;
}

TEST(McapMatrix, EveryFileFromTheReferenceWriterIsReadCompletely) {
  const std::vector<fs::path> files = matrix_files();
  ASSERT_FALSE(files.empty());
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.filename().string());
    const Json::Value manifest = manifest_of(file);
    std::map<std::string, std::uint64_t> expected;
    for (const std::string& topic : manifest["messages"].getMemberNames()) {
      expected[topic] = manifest["messages"][topic].asUInt64();
    }
    try {
      McapReader reader(file.string());
      EXPECT_FALSE(reader.salvage_mode()) << reader.salvage_error();
      EXPECT_NO_THROW(reader.verify());
      EXPECT_EQ(read_counts(reader, ReadOrder::kLogTime), expected);
      EXPECT_EQ(read_counts(reader, ReadOrder::kFile), expected);
      EXPECT_EQ(reader.metadata().size(), manifest["metadata"].asUInt64());
    } catch (const std::exception& e) {
      ADD_FAILURE() << e.what();
    }
  }
}

// Each file's Chunk records carry the compression its manifest names ("" for none): as many
// compressed chunks as the writer compressed, and the same compression in the summary's Chunk
// Index records and chunk count in its Statistics, when the file has them. Files written with a
// compression but without chunks (useChunks off, no messages) hold no Chunk at all.
TEST(McapMatrix, ChunksAreCompressedAsTheManifestSays) {
  const std::vector<fs::path> files = matrix_files();
  ASSERT_FALSE(files.empty());
  std::map<std::string, std::uint64_t> chunks_by_compression;  // over the whole matrix
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.filename().string());
    const Json::Value manifest = manifest_of(file);
    const Json::Value& options = manifest["options"];
    ASSERT_TRUE(options.isMember("compression")) << "manifest without options.compression";
    const std::string compression = options["compression"].asString();
    std::uint64_t messages = 0;
    for (const std::string& topic : manifest["messages"].getMemberNames()) {
      messages += manifest["messages"][topic].asUInt64();
    }
    try {
      const std::vector<std::string> chunks = chunk_compressions(file);
      for (std::size_t i = 0; i < chunks.size(); ++i) {
        EXPECT_EQ(chunks[i], compression) << "Chunk " << i;
      }
      EXPECT_EQ(compression.empty() ? 0u : chunks.size(), manifest["compressedChunks"].asUInt64());
      EXPECT_EQ(!chunks.empty(), options["useChunks"].asBool() && messages > 0) << chunks.size() << " chunks";
      chunks_by_compression[compression] += chunks.size();

      McapReader reader(file.string());
      for (const mcap::ChunkIndex& ci : reader.chunk_indexes()) {
        EXPECT_EQ(ci.compression, compression) << "Chunk Index for offset " << ci.chunk_start_offset;
      }
      if (options["useChunkIndex"].asBool()) {
        EXPECT_EQ(reader.chunk_indexes().size(), chunks.size());
      }
      if (reader.statistics()) {
        EXPECT_EQ(reader.statistics()->chunk_count, chunks.size());
      }
    } catch (const std::exception& e) {
      ADD_FAILURE() << e.what();
    }
  }
  EXPECT_GT(chunks_by_compression["zstd"], 0u) << "no zstd chunk in the matrix";
  EXPECT_GT(chunks_by_compression["lz4"], 0u) << "no lz4 chunk in the matrix";
  EXPECT_GT(chunks_by_compression[""], 0u) << "no uncompressed chunk in the matrix";
}

}  // namespace
}  // namespace fuse::io

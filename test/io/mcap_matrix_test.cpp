// MCAP files written by @mcap/core's McapWriter (interop/write_matrix.mjs: every writer option
// off on its own and in pairs, files without messages or metadata, small chunks) are read
// completely by our reader, in log-time and in file order, and verify; the messages per topic and
// the Metadata records are what the writer's manifest (FILE.json) says it wrote.
#include <gtest/gtest.h>
#include <json/json.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "fuse/io/mcap_reader.hpp"

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

TEST(McapMatrix, EveryFileFromTheReferenceWriterIsReadCompletely) {
  const char* dir = std::getenv("FUSE_MCAP_MATRIX_DIR");
  ASSERT_NE(dir, nullptr) << "FUSE_MCAP_MATRIX_DIR is not set";
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() == ".mcap") files.push_back(e.path());
  }
  ASSERT_GE(files.size(), 40u) << "the writer's matrix is missing from " << dir;
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

}  // namespace
}  // namespace fuse::io

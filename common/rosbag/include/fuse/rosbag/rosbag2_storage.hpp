// rosbag2 storage files, each a BagReader of its own:
//  - sqlite3 (.db3, rosbag2_storage_default_plugins): tables topics(id, name, type,
//    serialization_format, ...) and messages(id, topic_id, timestamp, data); read-only.
//  - MCAP (.mcap, rosbag2_storage_mcap): channels are topics, the schema name is the type, the
//    message encoding "cdr" (or "ros1"); read with fuse::io::McapReader.
#pragma once

#include <memory>
#include <string>

#include "fuse/rosbag/bag_reader.hpp"

namespace fuse::rosbag {

std::unique_ptr<BagReader> open_sqlite3_storage(const std::string& path);
std::unique_ptr<BagReader> open_mcap_storage(const std::string& path);

}  // namespace fuse::rosbag

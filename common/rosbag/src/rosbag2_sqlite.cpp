// rosbag2 sqlite3 storage (rosbag2_storage_default_plugins, SqliteStorage): schema
//   topics(id INTEGER PRIMARY KEY, name TEXT, type TEXT, serialization_format TEXT, ...)
//   messages(id INTEGER PRIMARY KEY, topic_id INTEGER, timestamp INTEGER, data BLOB)
// Messages are read ordered by timestamp (then id, the insertion order).
#include <sqlite3.h>

#include <algorithm>
#include <map>

#include "fuse/io/sensor_source.hpp"
#include "fuse/rosbag/rosbag2_storage.hpp"

namespace fuse::rosbag {

using io::InputError;

namespace {

class Sqlite3Storage final : public BagReader {
 public:
  explicit Sqlite3Storage(const std::string& path) : path_(path) {
    if (sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
      const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      db_ = nullptr;
      throw InputError(path + ": cannot open as sqlite3: " + why);
    }
    try {
      read_topics();
    } catch (...) {
      sqlite3_close(db_);
      db_ = nullptr;
      throw;
    }
  }
  ~Sqlite3Storage() override {
    sqlite3_finalize(stmt_);
    sqlite3_close(db_);
  }

  const std::vector<BagTopic>& topics() const override { return topics_; }
  std::uint64_t start_time_ns() const override { return start_; }
  std::uint64_t end_time_ns() const override { return end_; }
  std::string describe() const override { return path_ + " (rosbag2 sqlite3)"; }

  void start(const std::vector<std::string>& names) override {
    sqlite3_finalize(stmt_);
    stmt_ = nullptr;
    std::string sql = "SELECT topic_id, timestamp, data FROM messages";
    if (!names.empty()) {
      std::string ids;
      for (const auto& [id, index] : index_of_) {
        if (std::find(names.begin(), names.end(), topics_[index].name) != names.end()) {
          ids += (ids.empty() ? "" : ",") + std::to_string(id);
        }
      }
      sql += " WHERE topic_id IN (" + ids + ")";
    }
    sql += " ORDER BY timestamp, id";
    stmt_ = prepare(sql);
  }

  bool next(BagMessage& out) override {
    if (stmt_ == nullptr) throw InputError(path_ + ": next() before start()");
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_DONE) return false;
    if (rc != SQLITE_ROW) fail("reading messages");
    const sqlite3_int64 topic_id = sqlite3_column_int64(stmt_, 0);
    const sqlite3_int64 t = sqlite3_column_int64(stmt_, 1);
    const auto it = index_of_.find(topic_id);
    if (it == index_of_.end()) {
      throw InputError(path_ + ": message of topic id " + std::to_string(topic_id) + ", which the topics table lacks");
    }
    if (t < 0) throw InputError(path_ + ": message with negative timestamp " + std::to_string(t));
    if (sqlite3_column_type(stmt_, 2) != SQLITE_BLOB && sqlite3_column_type(stmt_, 2) != SQLITE_NULL) {
      throw InputError(path_ + ": message data is not a BLOB");
    }
    const auto* p = static_cast<const std::uint8_t*>(sqlite3_column_blob(stmt_, 2));
    const int n = sqlite3_column_bytes(stmt_, 2);
    out.topic = it->second;
    out.time_ns = static_cast<std::uint64_t>(t);
    out.data.assign(p, p + (p ? n : 0));
    return true;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(path_ + ": sqlite3 error while " + what + ": " + sqlite3_errmsg(db_));
  }
  sqlite3_stmt* prepare(const std::string& sql) {
    sqlite3_stmt* s = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &s, nullptr) != SQLITE_OK) {
      fail("preparing \"" + sql + "\" (not a rosbag2 sqlite3 file?)");
    }
    return s;
  }
  static std::string text(sqlite3_stmt* s, int col) {
    const auto* p = sqlite3_column_text(s, col);
    return p ? reinterpret_cast<const char*>(p) : "";
  }

  void read_topics() {
    struct Finalize {
      sqlite3_stmt* s;
      ~Finalize() { sqlite3_finalize(s); }
    };
    Finalize q{prepare("SELECT id, name, type, serialization_format FROM topics ORDER BY id")};
    int rc;
    while ((rc = sqlite3_step(q.s)) == SQLITE_ROW) {
      BagTopic t;
      const sqlite3_int64 id = sqlite3_column_int64(q.s, 0);
      t.name = text(q.s, 1);
      t.type = text(q.s, 2);
      const std::string format = text(q.s, 3);
      if (format == "cdr") {
        t.serialization = Serialization::kCdr;
      } else if (format == "ros1") {
        t.serialization = Serialization::kRos1;
      } else {
        throw InputError(path_ + ": topic " + t.name + " has serialization format '" + format + "' (supported: cdr, ros1)");
      }
      if (t.name.empty() || t.type.empty()) throw InputError(path_ + ": topic " + std::to_string(id) + " without name or type");
      index_of_[id] = topics_.size();
      topics_.push_back(std::move(t));
    }
    if (rc != SQLITE_DONE) fail("reading the topics table");
    Finalize c{prepare("SELECT topic_id, COUNT(*), MIN(timestamp), MAX(timestamp) FROM messages GROUP BY topic_id")};
    bool any = false;
    while ((rc = sqlite3_step(c.s)) == SQLITE_ROW) {
      const auto it = index_of_.find(sqlite3_column_int64(c.s, 0));
      if (it == index_of_.end()) throw InputError(path_ + ": messages of a topic id the topics table lacks");
      topics_[it->second].message_count = static_cast<std::uint64_t>(sqlite3_column_int64(c.s, 1));
      const auto lo = static_cast<std::uint64_t>(std::max<sqlite3_int64>(0, sqlite3_column_int64(c.s, 2)));
      const auto hi = static_cast<std::uint64_t>(std::max<sqlite3_int64>(0, sqlite3_column_int64(c.s, 3)));
      start_ = any ? std::min(start_, lo) : lo;
      end_ = any ? std::max(end_, hi) : hi;
      any = true;
    }
    if (rc != SQLITE_DONE) fail("counting messages");
  }

  std::string path_;
  sqlite3* db_ = nullptr;
  sqlite3_stmt* stmt_ = nullptr;
  std::vector<BagTopic> topics_;
  std::map<sqlite3_int64, std::size_t> index_of_;
  std::uint64_t start_ = 0, end_ = 0;
};

}  // namespace

std::unique_ptr<BagReader> open_sqlite3_storage(const std::string& path) {
  return std::make_unique<Sqlite3Storage>(path);
}

}  // namespace fuse::rosbag

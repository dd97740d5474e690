#include "output.hpp"

#include <cstdio>

namespace fuse::map_ctl {

namespace {
std::string json_string(const std::string& text) {
  std::string s = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      s += '\\';
      s += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof(buf), "\\u%04x", static_cast<unsigned>(c));
      s += buf;
    } else {
      s += c;
    }
  }
  return s + "\"";
}

std::string line(const std::string& name, const std::string& value) {
  return name + std::string(name.size() < 10 ? 10 - name.size() : 1, ' ') + value + "\n";
}
}  // namespace

std::string status_name(fuse_msgs::RpcStatus status) {
  switch (status) {
    case fuse_msgs::RPC_OK: return "ok";
    case fuse_msgs::RPC_BAD_REQUEST: return "bad_request";
    case fuse_msgs::RPC_NOT_READY: return "not_ready";
    case fuse_msgs::RPC_UNAVAILABLE: return "unavailable";
    case fuse_msgs::RPC_INTERNAL_ERROR: return "internal_error";
  }
  return "unknown";
}

std::string format_text(const fuse_msgs::MapControlReply& r) {
  std::string s = line("mode", r.mode().to_string()) + line("epoch", std::to_string(r.epoch())) +
                  line("points", std::to_string(r.points())) + line("chunks", std::to_string(r.chunks())) +
                  line("acked", std::to_string(r.acked_sequence())) +
                  line("journal", std::to_string(r.journal_records()) + " records");
  if (r.path().size() > 0) s += line("path", r.path().to_string());
  return s;
}

std::string format_json(const std::string& command, fuse_msgs::RpcStatus status, const std::string& message,
                        const fuse_msgs::MapControlReply& r) {
  return "{\"command\":" + json_string(command) + ",\"status\":" + json_string(status_name(status)) +
         ",\"message\":" + json_string(message) + ",\"mode\":" + json_string(r.mode().to_string()) +
         ",\"epoch\":" + std::to_string(r.epoch()) + ",\"points\":" + std::to_string(r.points()) +
         ",\"chunks\":" + std::to_string(r.chunks()) + ",\"acked_sequence\":" + std::to_string(r.acked_sequence()) +
         ",\"journal_records\":" + std::to_string(r.journal_records()) +
         ",\"path\":" + json_string(r.path().to_string()) + "}\n";
}

}  // namespace fuse::map_ctl

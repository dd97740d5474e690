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

/// A session id as fuse-update logs it: 16 hex digits.
std::string session_hex(std::uint64_t session) {
  char buf[24];
  std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(session));
  return buf;
}

std::string load_damage(const fuse_msgs::MapControlReply& r) {
  if (r.load_damaged_ranges() == 0 && r.load_chunks_lost() == 0) return "none";
  return std::to_string(r.load_bytes_skipped()) + " bytes in " + std::to_string(r.load_damaged_ranges()) +
         " damaged ranges skipped; " + std::to_string(r.load_observations_lost()) + " journal observations, " +
         std::to_string(r.load_chunks_lost()) + " snapshot chunks lost";
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
  const std::string state = r.state().to_string();
  std::string s = line("state", r.state_reason().size() > 0 ? state + " (" + r.state_reason().to_string() + ")" : state) +
                  line("mode", r.mode().to_string()) + line("epoch", std::to_string(r.epoch())) +
                  line("points", std::to_string(r.points())) + line("chunks", std::to_string(r.chunks())) +
                  line("acked", std::to_string(r.acked_sequence())) +
                  line("journal", std::to_string(r.journal_records()) + " records, " +
                                      std::to_string(r.journal_errors()) + " write errors") +
                  line("pending", std::to_string(r.pending_observations()) + " observations (" +
                                      std::to_string(r.pending_bytes()) + " bytes), " +
                                      std::to_string(r.pending_dropped()) + " dropped") +
                  line("damage", load_damage(r));
  for (const fuse_msgs::SessionAck& a : r.sessions()) {
    s += line("session", session_hex(a.session()) + " acked " + std::to_string(a.acked_sequence()));
  }
  if (r.path().size() > 0) s += line("path", r.path().to_string());
  return s;
}

std::string format_json(const std::string& command, fuse_msgs::RpcStatus status, const std::string& message,
                        const fuse_msgs::MapControlReply& r) {
  // Sessions as strings of 16 hex digits: 64-bit ids do not survive JSON numbers in every reader.
  std::string sessions = "[";
  for (const fuse_msgs::SessionAck& a : r.sessions()) {
    if (sessions.size() > 1) sessions += ",";
    sessions += "{\"session\":" + json_string(session_hex(a.session())) +
                ",\"acked_sequence\":" + std::to_string(a.acked_sequence()) + "}";
  }
  sessions += "]";
  return "{\"command\":" + json_string(command) + ",\"status\":" + json_string(status_name(status)) +
         ",\"message\":" + json_string(message) + ",\"mode\":" + json_string(r.mode().to_string()) +
         ",\"epoch\":" + std::to_string(r.epoch()) + ",\"points\":" + std::to_string(r.points()) +
         ",\"chunks\":" + std::to_string(r.chunks()) + ",\"acked_sequence\":" + std::to_string(r.acked_sequence()) +
         ",\"journal_records\":" + std::to_string(r.journal_records()) +
         ",\"path\":" + json_string(r.path().to_string()) + ",\"state\":" + json_string(r.state().to_string()) +
         ",\"state_reason\":" + json_string(r.state_reason().to_string()) +
         ",\"journal_errors\":" + std::to_string(r.journal_errors()) +
         ",\"pending_observations\":" + std::to_string(r.pending_observations()) +
         ",\"pending_bytes\":" + std::to_string(r.pending_bytes()) +
         ",\"pending_dropped\":" + std::to_string(r.pending_dropped()) +
         ",\"load_bytes_skipped\":" + std::to_string(r.load_bytes_skipped()) +
         ",\"load_damaged_ranges\":" + std::to_string(r.load_damaged_ranges()) +
         ",\"load_observations_lost\":" + std::to_string(r.load_observations_lost()) +
         ",\"load_chunks_lost\":" + std::to_string(r.load_chunks_lost()) + ",\"sessions\":" + sessions + "}\n";
}

std::string result_name(fuse_msgs::SetPoseResult result) {
  switch (result) {
    case fuse_msgs::SET_POSE_ACCEPTED: return "accepted";
    case fuse_msgs::SET_POSE_CORRECTED: return "corrected";
    case fuse_msgs::SET_POSE_REFUSED: return "refused";
    case fuse_msgs::SET_POSE_PENDING: return "pending";
  }
  return "unknown";
}

namespace {
std::string number(double v, int decimals) {
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}
constexpr double kDeg = 180.0 / 3.14159265358979323846;
}  // namespace

std::string format_text(const fuse_msgs::SetPoseReply& r) {
  std::string out = line("result", result_name(r.result()));
  if (r.result() == fuse_msgs::SET_POSE_ACCEPTED || r.result() == fuse_msgs::SET_POSE_CORRECTED) {
    out += line("position", number(r.position().x(), 3) + " " + number(r.position().y(), 3) + " " +
                                number(r.position().z(), 3) + " m");
    out += line("yaw", number(r.yaw() * kDeg, 2) + " deg");
    out += line("offset", number(r.offset(), 3) + " m");
    out += line("turn", number(r.turn() * kDeg, 2) + " deg");
  }
  return out + line("detail", std::string(r.detail()));
}

std::string format_json(fuse_msgs::RpcStatus status, const std::string& message, const fuse_msgs::SetPoseReply& r) {
  std::string s = "{\"command\": \"set-pose\", \"status\": " + json_string(status_name(status)) +
                  ", \"message\": " + json_string(message);
  if (status == fuse_msgs::RPC_OK) {
    s += ", \"result\": " + json_string(result_name(r.result())) + ", \"position\": [" + number(r.position().x(), 6) +
         ", " + number(r.position().y(), 6) + ", " + number(r.position().z(), 6) + "], \"yaw\": " + number(r.yaw(), 6) +
         ", \"offset\": " + number(r.offset(), 6) + ", \"turn\": " + number(r.turn(), 6) +
         ", \"detail\": " + json_string(std::string(r.detail()));
  }
  return s + "}\n";
}

}  // namespace fuse::map_ctl

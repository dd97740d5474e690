#include "output.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <vector>

namespace fuse::query_tool {

namespace {
/// Shortest text that reads back to the same double ("inf", "nan" when not finite).
std::string number(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, r.ptr);
}

/// A JSON number; JSON has no NaN or infinity, so those are null.
std::string json_number(double v) { return std::isfinite(v) ? number(v) : "null"; }

template <std::size_t N>
std::vector<double> diagonal(const std::array<double, N * N>& m) {
  std::vector<double> d(N);
  for (std::size_t i = 0; i < N; ++i) d[i] = m[i * N + i];
  return d;
}

template <class Values>
std::string text_list(const Values& values) {
  std::string s;
  for (double v : values) s += (s.empty() ? "" : " ") + number(v);
  return s;
}

template <class Values>
std::string json_list(const Values& values) {
  std::string s = "[";
  for (double v : values) s += (s.size() > 1 ? "," : "") + json_number(v);
  return s + "]";
}

std::string json_string(const std::string& text) {
  std::string s = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') {
      s += '\\';
      s += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof(buf), "\\u%04x", c);
      s += buf;
    } else {
      s += c;
    }
  }
  return s + "\"";
}

/// t on the host clocks, when fuse-state has a mapping.
std::string host_clock_text(const query::Estimate& e) {
  if (!e.host_clock.known) return "\nhost_clock: unknown";
  return "\nhost_realtime: " + number(e.t + e.host_clock.realtime_offset) +
         "\nhost_monotonic: " + number(e.t + e.host_clock.monotonic_offset);
}

std::string host_clock_json(const query::Estimate& e) {
  if (!e.host_clock.known) return "null";
  return "{\"realtime_offset\":" + json_number(e.host_clock.realtime_offset) +
         ",\"monotonic_offset\":" + json_number(e.host_clock.monotonic_offset) + "}";
}
}  // namespace

std::string format_text(const query::Result& r) {
  const query::Estimate& e = r.estimate;
  return "t: " + number(e.t) + "\nstatus: " + query::to_string(e.status) + "\nposition: " + text_list(e.position) +
         "\nframe: " + e.frame_id + " <- " + e.child_frame_id +
         "\norientation_xyzw: " + text_list(e.orientation_xyzw) + "\nvelocity: " + text_list(e.velocity) +
         "\nangular_velocity: " + text_list(e.angular_velocity) +
         "\npose_covariance_diagonal: " + text_list(diagonal<6>(e.pose_covariance)) +
         "\nvelocity_covariance_diagonal: " + text_list(diagonal<3>(e.velocity_covariance)) + host_clock_text(e) + "\n";
}

std::string format_json(const query::Result& r) {
  std::string s = "{\"error\":" + json_string(query::to_string(r.error)) + ",\"message\":" + json_string(r.message);
  // The estimate is there when it was answered (ok), and as the best guess with its status when
  // it is not one to steer by.
  if (r.ok() || r.error == query::Error::out_of_range || r.error == query::Error::not_tracking) {
    const query::Estimate& e = r.estimate;
    s += ",\"t\":" + json_number(e.t) + ",\"status\":" + json_string(query::to_string(e.status)) +
         ",\"position\":" + json_list(e.position) + ",\"orientation_xyzw\":" + json_list(e.orientation_xyzw) +
         ",\"velocity\":" + json_list(e.velocity) + ",\"angular_velocity\":" + json_list(e.angular_velocity) +
         ",\"frame_id\":" + json_string(e.frame_id) + ",\"child_frame_id\":" + json_string(e.child_frame_id) +
         ",\"host_clock\":" + host_clock_json(e) +
         ",\"pose_covariance_diagonal\":" + json_list(diagonal<6>(e.pose_covariance)) +
         ",\"velocity_covariance_diagonal\":" + json_list(diagonal<3>(e.velocity_covariance)) +
         ",\"pose_covariance\":" + json_list(e.pose_covariance) +
         ",\"velocity_covariance\":" + json_list(e.velocity_covariance);
  }
  return s + "}\n";
}

}  // namespace fuse::query_tool

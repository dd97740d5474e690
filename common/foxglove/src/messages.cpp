// JSON encoders and JSON Schemas of the Foxglove message schemas FUSE publishes
// (fuse/foxglove/messages.hpp). The schemas are built as JSON values, so their text is valid JSON.
#include "fuse/foxglove/messages.hpp"

#include <json/json.h>

#include <cmath>
#include <cstring>

namespace fuse::foxglove {
namespace {

constexpr double kNanosecondsPerSecond = 1e9;
constexpr int kFloat32 = 7;           // foxglove.NumericType FLOAT32
constexpr std::uint32_t kXyzStride = 12;  // three float32

std::string to_json(const Json::Value& value) {
  Json::StreamWriterBuilder builder;
  builder["indentation"] = "";
  return Json::writeString(builder, value);
}

Json::Value typed(const char* type) {
  Json::Value v;
  v["type"] = type;
  return v;
}

Json::Value object(const std::string& title, const std::vector<std::pair<std::string, Json::Value>>& properties) {
  Json::Value v;
  v["title"] = title;
  v["type"] = "object";
  v["properties"] = Json::Value(Json::objectValue);
  for (const auto& [name, schema] : properties) v["properties"][name] = schema;
  return v;
}

Json::Value array_of(const Json::Value& item) {
  Json::Value v = typed("array");
  v["items"] = item;
  return v;
}

Json::Value time_schema() {
  Json::Value sec = typed("integer"), nsec = typed("integer");
  sec["minimum"] = 0;
  nsec["minimum"] = 0;
  nsec["maximum"] = 999999999;
  return object("time", {{"sec", sec}, {"nsec", nsec}});
}
Json::Value vector3_schema() {
  return object("foxglove.Vector3", {{"x", typed("number")}, {"y", typed("number")}, {"z", typed("number")}});
}
Json::Value quaternion_schema() {
  return object("foxglove.Quaternion",
                {{"x", typed("number")}, {"y", typed("number")}, {"z", typed("number")}, {"w", typed("number")}});
}
Json::Value pose_schema() {
  return object("foxglove.Pose", {{"position", vector3_schema()}, {"orientation", quaternion_schema()}});
}
Json::Value frame_transform_schema() {
  return object("foxglove.FrameTransform", {{"timestamp", time_schema()},
                                            {"parent_frame_id", typed("string")},
                                            {"child_frame_id", typed("string")},
                                            {"translation", vector3_schema()},
                                            {"rotation", quaternion_schema()}});
}

JsonSchema make(const std::string& name, Json::Value schema) {
  schema["$schema"] = "https://json-schema.org/draft/2020-12/schema";
  return JsonSchema{name, to_json(schema)};
}

Json::Value time_json(double t) {
  const std::uint64_t ns = to_nanoseconds(t);
  Json::Value v;
  v["sec"] = static_cast<Json::UInt64>(ns / 1000000000u);
  v["nsec"] = static_cast<Json::UInt64>(ns % 1000000000u);
  return v;
}

Json::Value pose_json(const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.linear());
  Json::Value v;
  v["position"]["x"] = T.translation().x();
  v["position"]["y"] = T.translation().y();
  v["position"]["z"] = T.translation().z();
  v["orientation"]["x"] = q.x();
  v["orientation"]["y"] = q.y();
  v["orientation"]["z"] = q.z();
  v["orientation"]["w"] = q.w();
  return v;
}

}  // namespace

const JsonSchema& pose_in_frame_schema() {
  static const JsonSchema s = make(
      "foxglove.PoseInFrame",
      object("foxglove.PoseInFrame", {{"timestamp", time_schema()}, {"frame_id", typed("string")}, {"pose", pose_schema()}}));
  return s;
}

const JsonSchema& poses_in_frame_schema() {
  static const JsonSchema s = make("foxglove.PosesInFrame",
                                   object("foxglove.PosesInFrame", {{"timestamp", time_schema()},
                                                                    {"frame_id", typed("string")},
                                                                    {"poses", array_of(pose_schema())}}));
  return s;
}

const JsonSchema& frame_transforms_schema() {
  static const JsonSchema s = make("foxglove.FrameTransforms",
                                   object("foxglove.FrameTransforms", {{"transforms", array_of(frame_transform_schema())}}));
  return s;
}

const JsonSchema& point_cloud_schema() {
  Json::Value type = typed("integer");
  type["description"] = "foxglove.NumericType: 1 UINT8, 2 INT8, 3 UINT16, 4 INT16, 5 UINT32, 6 INT32, 7 FLOAT32, 8 FLOAT64";
  type["minimum"] = 0;
  type["maximum"] = 8;
  Json::Value data = typed("string");
  data["contentEncoding"] = "base64";
  static const JsonSchema s = make(
      "foxglove.PointCloud",
      object("foxglove.PointCloud",
             {{"timestamp", time_schema()},
              {"frame_id", typed("string")},
              {"pose", pose_schema()},
              {"point_stride", typed("integer")},
              {"fields", array_of(object("foxglove.PackedElementField",
                                         {{"name", typed("string")}, {"offset", typed("integer")}, {"type", type}}))},
              {"data", data}}));
  return s;
}

const JsonSchema& health_schema() {
  Json::Value counters = typed("object");
  counters["additionalProperties"] = typed("integer");
  static const JsonSchema s = make("fuse.Health", object("fuse.Health", {{"timestamp", time_schema()},
                                                                         {"service", typed("string")},
                                                                         {"instance", typed("integer")},
                                                                         {"state", typed("string")},
                                                                         {"uptime_s", typed("number")},
                                                                         {"last_error", typed("string")},
                                                                         {"counters", counters}}));
  return s;
}

std::uint64_t to_nanoseconds(double t) {
  if (!(t > 0.0) || !std::isfinite(t)) return 0;
  return static_cast<std::uint64_t>(std::llround(t * kNanosecondsPerSecond));
}

std::string pose_in_frame_json(double t, const std::string& frame, const Eigen::Isometry3d& T_frame_body) {
  Json::Value v;
  v["timestamp"] = time_json(t);
  v["frame_id"] = frame;
  v["pose"] = pose_json(T_frame_body);
  return to_json(v);
}

std::string poses_in_frame_json(double t, const std::string& frame, const std::vector<Eigen::Isometry3d>& poses) {
  Json::Value v;
  v["timestamp"] = time_json(t);
  v["frame_id"] = frame;
  v["poses"] = Json::Value(Json::arrayValue);
  for (const Eigen::Isometry3d& T : poses) v["poses"].append(pose_json(T));
  return to_json(v);
}

std::string frame_transforms_json(const std::vector<StampedTransform>& transforms) {
  Json::Value v;
  v["transforms"] = Json::Value(Json::arrayValue);
  for (const StampedTransform& tf : transforms) {
    const Json::Value pose = pose_json(tf.T_parent_child);
    Json::Value t;
    t["timestamp"] = time_json(tf.t);
    t["parent_frame_id"] = tf.parent;
    t["child_frame_id"] = tf.child;
    t["translation"] = pose["position"];
    t["rotation"] = pose["orientation"];
    v["transforms"].append(t);
  }
  return to_json(v);
}

std::string point_cloud_json(double t, const std::string& frame, const std::vector<float>& xyz) {
  Json::Value head;
  head["timestamp"] = time_json(t);
  head["frame_id"] = frame;
  head["pose"] = pose_json(Eigen::Isometry3d::Identity());
  head["point_stride"] = kXyzStride;
  head["fields"] = Json::Value(Json::arrayValue);
  for (std::uint32_t i = 0; i < 3; ++i) {
    Json::Value field;
    field["name"] = std::string(1, static_cast<char>('x' + i));
    field["offset"] = 4 * i;
    field["type"] = kFloat32;
    head["fields"].append(field);
  }
  head["data"] = "";
  // The data is appended as text: a JSON value of megabytes is not built twice.
  std::string json = to_json(head);
  static_assert(sizeof(float) == 4, "float32 points");
  std::string data;
  if (!xyz.empty()) {
    std::vector<std::uint8_t> bytes(xyz.size() * sizeof(float));
    std::memcpy(bytes.data(), xyz.data(), bytes.size());  // little-endian hosts only (x86-64, arm64)
    data = base64(bytes.data(), bytes.size());
  }
  const std::string empty_data = "\"data\":\"\"";
  const auto at = json.find(empty_data);
  json.replace(at, empty_data.size(), "\"data\":\"" + data + "\"");
  return json;
}

std::string health_json(const HealthView& h) {
  Json::Value v;
  v["timestamp"] = time_json(h.t);
  v["service"] = h.service;
  v["instance"] = static_cast<Json::UInt64>(h.instance);
  v["state"] = h.state;
  v["uptime_s"] = h.uptime_s;
  v["last_error"] = h.last_error;
  v["counters"] = Json::Value(Json::objectValue);
  for (const auto& [name, value] : h.counters) v["counters"][name] = static_cast<Json::UInt64>(value);
  return to_json(v);
}

std::string base64(const std::uint8_t* data, std::size_t size) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < size; i += 3) {
    const std::uint32_t n = (std::uint32_t{data[i]} << 16) | (std::uint32_t{data[i + 1]} << 8) | data[i + 2];
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += kAlphabet[(n >> 6) & 63];
    out += kAlphabet[n & 63];
  }
  if (i < size) {
    const bool two = i + 1 < size;
    const std::uint32_t n = (std::uint32_t{data[i]} << 16) | (two ? std::uint32_t{data[i + 1]} << 8 : 0);
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += two ? kAlphabet[(n >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

}  // namespace fuse::foxglove

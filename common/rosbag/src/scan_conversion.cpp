#include "fuse/rosbag/scan_conversion.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <vector>

#include "fuse/io/sensor_source.hpp"

namespace fuse::rosbag {

using io::InputError;

namespace {

/// Time field conventions, in the order "auto" tries them.
struct TimeConvention {
  const char* name;
  double scale_s;  ///< field value * scale_s = seconds
  bool absolute;
};
constexpr TimeConvention kTimeConventions[] = {
    {"t", 1e-9, false}, {"time", 1.0, false}, {"timestamp", 1.0, true}, {"offset_time", 1e-9, false}};

/// Longest time a scan's points may span, and farthest they may lie from the header stamp.
constexpr double kMaxScanSpanS = 10.0;
constexpr double kMaxStampOffsetS = 3600.0;

const PointField* find_field(const PointCloud2Msg& c, const char* name) {
  for (const auto& f : c.fields) {
    if (f.name == name) return &f;
  }
  return nullptr;
}

/// One field's first element at `p`, as a double (the cloud's byte order).
double read_value(const std::uint8_t* p, std::uint8_t datatype, bool big_endian) {
  std::uint8_t b[8];
  const std::size_t n = point_field_size(datatype);
  std::memcpy(b, p, n);
  if (big_endian) std::reverse(b, b + n);
  switch (static_cast<PointFieldType>(datatype)) {
    case PointFieldType::kInt8: { std::int8_t v; std::memcpy(&v, b, 1); return v; }
    case PointFieldType::kUint8: return b[0];
    case PointFieldType::kInt16: { std::int16_t v; std::memcpy(&v, b, 2); return v; }
    case PointFieldType::kUint16: { std::uint16_t v; std::memcpy(&v, b, 2); return v; }
    case PointFieldType::kInt32: { std::int32_t v; std::memcpy(&v, b, 4); return v; }
    case PointFieldType::kUint32: { std::uint32_t v; std::memcpy(&v, b, 4); return v; }
    case PointFieldType::kFloat32: { float v; std::memcpy(&v, b, 4); return v; }
    case PointFieldType::kFloat64: { double v; std::memcpy(&v, b, 8); return v; }
  }
  return std::numeric_limits<double>::quiet_NaN();
}

/// Checks that `f` is a known datatype lying inside point_step.
void check_field(const PointCloud2Msg& c, const PointField& f, const std::string& context) {
  const std::size_t size = point_field_size(f.datatype);
  if (size == 0) throw InputError(context + ": field '" + f.name + "' has unknown datatype " + std::to_string(f.datatype));
  if (f.count == 0) throw InputError(context + ": field '" + f.name + "' has count 0");
  if (std::uint64_t{f.offset} + size > c.point_step) {
    throw InputError(context + ": field '" + f.name + "' (offset " + std::to_string(f.offset) + ", " +
                     std::to_string(size) + " bytes) lies outside point_step " + std::to_string(c.point_step));
  }
}

/// Point times that cannot belong to one scan mean a wrong time field or unit: refused.
void check_times(const std::vector<double>& offsets_s, const std::string& context) {
  if (offsets_s.empty()) return;
  const auto [lo, hi] = std::minmax_element(offsets_s.begin(), offsets_s.end());
  if (*hi - *lo > kMaxScanSpanS || std::abs(*lo) > kMaxStampOffsetS || std::abs(*hi) > kMaxStampOffsetS) {
    throw InputError(context + ": point times span " + std::to_string(*lo) + " .. " + std::to_string(*hi) +
                     " s around the header stamp; not one scan (wrong --time-field or unit?)");
  }
}

LidarScan finish(std::uint64_t stamp_ns, std::vector<LidarPoint>& pts, const std::vector<double>& offsets_s) {
  LidarScan scan;
  const double stamp_s = static_cast<double>(stamp_ns / 1000000000ull) + static_cast<double>(stamp_ns % 1000000000ull) * 1e-9;
  if (pts.empty()) {
    scan.t_start = scan.t_end = stamp_s;
    return scan;
  }
  const auto [lo, hi] = std::minmax_element(offsets_s.begin(), offsets_s.end());
  scan.t_start = stamp_s + *lo;
  scan.t_end = scan.t_start + (*hi - *lo);
  for (std::size_t i = 0; i < pts.size(); ++i) pts[i].t_rel = static_cast<float>(offsets_s[i] - *lo);
  scan.points = std::move(pts);
  return scan;
}

}  // namespace

bool known_time_field(const std::string& name) {
  return std::any_of(std::begin(kTimeConventions), std::end(kTimeConventions),
                     [&](const TimeConvention& c) { return name == c.name; });
}

LidarScan cloud_to_scan(const PointCloud2Msg& c, const std::string& time_field, PointCounts& counts,
                        const std::string& context) {
  const PointField* fx = find_field(c, "x");
  const PointField* fy = find_field(c, "y");
  const PointField* fz = find_field(c, "z");
  if (!fx || !fy || !fz) throw InputError(context + ": the cloud has no x, y, z fields");
  const PointField* fi = find_field(c, "intensity");
  if (!fi) fi = find_field(c, "reflectivity");
  const PointField* fr = find_field(c, "ring");
  if (!fr) fr = find_field(c, "line");

  const TimeConvention* conv = nullptr;
  const PointField* ft = nullptr;
  if (!time_field.empty() && !known_time_field(time_field)) {
    throw InputError(context + ": unknown time field convention '" + time_field + "' (t, time, timestamp, offset_time)");
  }
  for (const auto& tc : kTimeConventions) {
    if (!time_field.empty() && time_field != tc.name) continue;
    if ((ft = find_field(c, tc.name)) != nullptr) {
      conv = &tc;
      break;
    }
  }
  if (!ft) {
    std::string names;
    for (const auto& f : c.fields) names += (names.empty() ? "" : ", ") + f.name;
    throw InputError(context + ": no per-point time field " +
                     (time_field.empty() ? std::string("(t, time, timestamp or offset_time)") : "'" + time_field + "'") +
                     "; the cloud has fields " + names);
  }
  for (const PointField* f : {fx, fy, fz, fi, fr, ft}) {
    if (f) check_field(c, *f, context);
  }
  const std::uint64_t row_bytes = std::uint64_t{c.width} * c.point_step;
  if (c.point_step == 0 && c.width > 0) throw InputError(context + ": point_step is 0");
  if (c.height > 1 && c.row_step < row_bytes) {
    throw InputError(context + ": row_step " + std::to_string(c.row_step) + " is less than width * point_step " +
                     std::to_string(row_bytes));
  }
  const std::uint64_t stride = c.height > 1 ? c.row_step : row_bytes;
  const std::uint64_t needed = c.height == 0 ? 0 : (std::uint64_t{c.height} - 1) * stride + row_bytes;
  if (needed > c.data.size()) {
    throw InputError(context + ": " + std::to_string(c.height) + " x " + std::to_string(c.width) + " points of " +
                     std::to_string(c.point_step) + " bytes need " + std::to_string(needed) + " data bytes, the message has " +
                     std::to_string(c.data.size()));
  }

  std::vector<LidarPoint> pts;
  std::vector<double> offsets;
  pts.reserve(std::uint64_t{c.height} * c.width);
  offsets.reserve(pts.capacity());
  const double stamp_s = static_cast<double>(c.stamp_ns / 1000000000ull) + static_cast<double>(c.stamp_ns % 1000000000ull) * 1e-9;
  const bool be = c.is_bigendian;
  for (std::uint32_t row = 0; row < c.height; ++row) {
    for (std::uint32_t col = 0; col < c.width; ++col) {
      const std::uint8_t* p = c.data.data() + row * stride + std::uint64_t{col} * c.point_step;
      const double x = read_value(p + fx->offset, fx->datatype, be);
      const double y = read_value(p + fy->offset, fy->datatype, be);
      const double z = read_value(p + fz->offset, fz->datatype, be);
      const double tv = read_value(p + ft->offset, ft->datatype, be);
      const double off = conv->absolute ? tv - stamp_s : tv * conv->scale_s;
      LidarPoint pt;
      pt.x = static_cast<float>(x);  // a float64 beyond float range becomes inf: counted below
      pt.y = static_cast<float>(y);
      pt.z = static_cast<float>(z);
      if (fi) pt.intensity = static_cast<float>(read_value(p + fi->offset, fi->datatype, be));
      if (!std::isfinite(pt.x) || !std::isfinite(pt.y) || !std::isfinite(pt.z) || !std::isfinite(pt.intensity) ||
          !std::isfinite(off)) {
        ++counts.nan_points;
        continue;
      }
      if (x == 0.0 && y == 0.0 && z == 0.0) {
        ++counts.zero_points;
        continue;
      }
      if (fr) {
        const double ring = read_value(p + fr->offset, fr->datatype, be);
        pt.ring = ring >= 0 && ring <= 65535 ? static_cast<std::uint16_t>(ring) : 0;
      }
      pts.push_back(pt);
      offsets.push_back(off);
    }
  }
  check_times(offsets, context);
  counts.kept += pts.size();
  return finish(c.stamp_ns, pts, offsets);
}

LidarScan livox_to_scan(const LivoxCustomMsg& m, PointCounts& counts) {
  std::vector<LidarPoint> pts;
  std::vector<double> offsets;
  pts.reserve(m.points.size());
  offsets.reserve(m.points.size());
  for (const auto& q : m.points) {
    if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z)) {
      ++counts.nan_points;
      continue;
    }
    if (q.x == 0.f && q.y == 0.f && q.z == 0.f) {
      ++counts.zero_points;
      continue;
    }
    LidarPoint pt;
    pt.x = q.x;
    pt.y = q.y;
    pt.z = q.z;
    pt.intensity = q.reflectivity;
    pt.ring = q.line;
    pts.push_back(pt);
    offsets.push_back(q.offset_time * 1e-9);
  }
  counts.kept += pts.size();
  return finish(m.timebase, pts, offsets);
}

ImuSample imu_to_sample(const ImuMsg& m, double accel_scale) {
  ImuSample s;
  s.t = static_cast<double>(m.stamp_ns / 1000000000ull) + static_cast<double>(m.stamp_ns % 1000000000ull) * 1e-9;
  s.gyro = m.angular_velocity;
  s.accel = m.linear_acceleration * accel_scale;
  return s;
}

}  // namespace fuse::rosbag

#include "fuse/io/ouster_metadata.hpp"

#include <json/json.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "fuse/io/sensor_source.hpp"

namespace fuse::io::ouster {

namespace {

// Packet layout sizes (Ouster Sensor Docs, "Lidar Data Format" / "Sensor Data"): legacy
// columns are a 16-byte header, 12-byte pixels and a 4-byte status footer; the profile packets
// have a 32-byte packet header, 12-byte column headers, profile-sized pixels and a 32-byte footer.
constexpr std::size_t kLegacyColumnHeader = 16, kLegacyPixel = 12, kLegacyColumnFooter = 4;
constexpr std::size_t kPacketHeader = 32, kPacketFooter = 32, kColumnHeader = 12;

std::size_t pixel_bytes(LidarProfile p) {
  switch (p) {
    case LidarProfile::kRng19Rfl8Sig16Nir16:
      return 12;
    case LidarProfile::kRng15Rfl8Nir8:
      return 4;
    case LidarProfile::kRng19Rfl8Sig16Nir16Dual:
      return 16;
    case LidarProfile::kLegacy:
      break;
  }
  return kLegacyPixel;
}

/// Reads fields with their JSON path for messages.
class Reader {
 public:
  explicit Reader(std::string name) : name_(std::move(name)) {}

  [[noreturn]] void fail(const std::string& path, const std::string& what) const {
    throw InputError("Ouster metadata " + name_ + ": field '" + path + "' " + what);
  }
  const Json::Value* find(const Json::Value& obj, const char* key) const {
    if (!obj.isObject()) return nullptr;
    const Json::Value* v = obj.find(key, key + std::strlen(key));
    return v && !v->isNull() ? v : nullptr;
  }
  double number(const Json::Value& v, const std::string& path) const {
    if (!v.isNumeric()) fail(path, "is not a number");
    const double d = v.asDouble();
    if (!std::isfinite(d)) fail(path, "is not finite");
    return d;
  }
  int integer(const Json::Value& v, const std::string& path, int lo, int hi) const {
    if (!v.isNumeric()) fail(path, "is not a number");
    const double d = v.asDouble();
    if (d != std::floor(d) || d < lo || d > hi) {
      fail(path, "is " + v.toStyledString().substr(0, 40) + ", expected an integer in [" + std::to_string(lo) + ", " +
                     std::to_string(hi) + "]");
    }
    return static_cast<int>(d);
  }
  std::string string(const Json::Value& v, const std::string& path) const {
    if (!v.isString()) fail(path, "is not a string");
    return v.asString();
  }
  std::vector<double> numbers(const Json::Value& v, const std::string& path, std::size_t n_min,
                              std::size_t n_max) const {
    if (!v.isArray()) fail(path, "is not an array");
    if (v.size() < n_min || v.size() > n_max) {
      fail(path, "has " + std::to_string(v.size()) + " elements, expected " +
                     (n_min == n_max ? std::to_string(n_min) : std::to_string(n_min) + ".." + std::to_string(n_max)));
    }
    std::vector<double> out;
    for (Json::ArrayIndex i = 0; i < v.size(); ++i) out.push_back(number(v[i], path + "[" + std::to_string(i) + "]"));
    return out;
  }
  Eigen::Matrix4d transform(const Json::Value& v, const std::string& path) const {
    const auto m = numbers(v, path, 16, 16);
    Eigen::Matrix4d T;
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) T(r, c) = m[static_cast<std::size_t>(r * 4 + c)];
    }
    const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
    if ((R * R.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-3 || std::abs(R.determinant() - 1.0) > 1e-3 ||
        (T.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9) {
      fail(path, "is not a rigid transform (rotation not orthonormal or last row not 0 0 0 1)");
    }
    return T;
  }

 private:
  std::string name_;
};

/// First of the places a field may live: {object, key, path for messages}.
struct Place {
  const Json::Value* obj;
  const char* key;
  std::string path;
};

}  // namespace

const char* profile_name(LidarProfile p) {
  switch (p) {
    case LidarProfile::kLegacy:
      return "LEGACY";
    case LidarProfile::kRng19Rfl8Sig16Nir16:
      return "RNG19_RFL8_SIG16_NIR16";
    case LidarProfile::kRng15Rfl8Nir8:
      return "RNG15_RFL8_NIR8";
    case LidarProfile::kRng19Rfl8Sig16Nir16Dual:
      return "RNG19_RFL8_SIG16_NIR16_DUAL";
  }
  return "?";
}

int Metadata::window_columns() const {
  return column_window_first <= column_window_last ? column_window_last - column_window_first + 1
                                                   : columns_per_frame - column_window_first + column_window_last + 1;
}

bool Metadata::in_window(int m) const {
  return column_window_first <= column_window_last ? (m >= column_window_first && m <= column_window_last)
                                                   : (m >= column_window_first || m <= column_window_last);
}

std::size_t Metadata::lidar_packet_size() const {
  const auto cpp = static_cast<std::size_t>(columns_per_packet), ppc = static_cast<std::size_t>(pixels_per_column);
  if (lidar_profile == LidarProfile::kLegacy) {
    return cpp * (kLegacyColumnHeader + ppc * kLegacyPixel + kLegacyColumnFooter);
  }
  return kPacketHeader + cpp * (kColumnHeader + ppc * pixel_bytes(lidar_profile)) + kPacketFooter;
}

namespace {
Eigen::Isometry3d to_metres(const Eigen::Matrix4d& T_mm) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = T_mm.topLeftCorner<3, 3>();
  T.translation() = T_mm.topRightCorner<3, 1>() * 1e-3;
  return T;
}
}  // namespace

Eigen::Isometry3d Metadata::T_imu_sensor() const { return to_metres(imu_to_sensor).inverse(); }
Eigen::Isometry3d Metadata::T_imu_lidar() const { return T_imu_sensor() * to_metres(lidar_to_sensor); }

Metadata parse_metadata(const std::string& text, const std::string& name) {
  Json::CharReaderBuilder builder;
  builder["collectComments"] = false;
  Json::Value root;
  std::string errors;
  std::istringstream in(text);
  if (!Json::parseFromStream(builder, in, &root, &errors)) {
    throw InputError("Ouster metadata " + name + ": not valid JSON: " + errors.substr(0, 200));
  }
  if (!root.isObject()) throw InputError("Ouster metadata " + name + ": the top level is not a JSON object");
  Reader rd(name);
  Metadata m;
  m.name = name;

  const Json::Value null;
  auto section = [&](const char* key) -> const Json::Value& {
    const Json::Value* v = rd.find(root, key);
    if (v && !v->isObject()) rd.fail(key, "is not an object");
    return v ? *v : null;
  };
  const Json::Value& beam = section("beam_intrinsics");
  const Json::Value& lidar_intr = section("lidar_intrinsics");
  const Json::Value& imu_intr = section("imu_intrinsics");
  const Json::Value& sensor_info = section("sensor_info");
  const Json::Value& config = section("config_params");
  const Json::Value* fmt_p = rd.find(root, "lidar_data_format");
  std::string fmt_name = "lidar_data_format";
  if (!fmt_p) {
    fmt_p = rd.find(root, "data_format");
    fmt_name = "data_format";
  }
  if (fmt_p && !fmt_p->isObject()) rd.fail(fmt_name, "is not an object");
  const Json::Value& fmt = fmt_p ? *fmt_p : null;

  // A field from the first place that has it (nested layout first, then the flat one).
  auto lookup = [&](std::initializer_list<Place> places, std::string* path) -> const Json::Value* {
    for (const auto& p : places) {
      if (const Json::Value* v = rd.find(*p.obj, p.key)) {
        *path = p.path;
        return v;
      }
    }
    return nullptr;
  };
  auto required = [&](std::initializer_list<Place> places, std::string* path) -> const Json::Value& {
    const Json::Value* v = lookup(places, path);
    if (!v) {
      std::string all;
      for (const auto& p : places) all += (all.empty() ? "" : " or ") + p.path;
      throw InputError("Ouster metadata " + name + ": field '" + all + "' is missing");
    }
    return *v;
  };
  std::string path;

  // Identification (optional: used to tell sensors apart on shared ports).
  if (const auto* v = lookup({{&sensor_info, "prod_line", "sensor_info.prod_line"}, {&root, "prod_line", "prod_line"}}, &path)) {
    m.prod_line = rd.string(*v, path);
  }
  if (const auto* v = lookup({{&sensor_info, "build_rev", "sensor_info.build_rev"}, {&root, "build_rev", "build_rev"}}, &path)) {
    m.firmware = rd.string(*v, path);
  }
  if (const auto* v = lookup({{&sensor_info, "prod_sn", "sensor_info.prod_sn"}, {&root, "prod_sn", "prod_sn"}}, &path)) {
    const std::string sn = v->isString() ? v->asString() : std::to_string(rd.integer(*v, path, 0, 2147483647));
    if (!sn.empty()) {
      try {
        std::size_t used = 0;
        m.serial = std::stoull(sn, &used);
        if (used != sn.size()) throw std::invalid_argument(sn);
      } catch (const std::exception&) {
        rd.fail(path, "is '" + sn + "', not a serial number");
      }
    }
  }
  if (const auto* v = lookup({{&sensor_info, "initialization_id", "sensor_info.initialization_id"},
                              {&root, "initialization_id", "initialization_id"}},
                             &path)) {
    m.init_id = static_cast<std::uint32_t>(rd.integer(*v, path, 0, 0xFFFFFF));
  }

  // Mode: columns per frame and frame rate ("1024x10").
  m.lidar_mode = rd.string(
      required({{&config, "lidar_mode", "config_params.lidar_mode"}, {&root, "lidar_mode", "lidar_mode"}}, &path), path);
  {
    const auto x = m.lidar_mode.find('x');
    int cols = 0, hz = 0;
    try {
      if (x == std::string::npos) throw std::invalid_argument(m.lidar_mode);
      cols = std::stoi(m.lidar_mode.substr(0, x));
      hz = std::stoi(m.lidar_mode.substr(x + 1));
    } catch (const std::exception&) {
      rd.fail(path, "is '" + m.lidar_mode + "', expected COLUMNSxHZ such as 1024x10");
    }
    if (cols != 512 && cols != 1024 && cols != 2048 && cols != 4096) rd.fail(path, "has " + std::to_string(cols) + " columns (512, 1024, 2048 or 4096)");
    if (hz != 5 && hz != 10 && hz != 20) rd.fail(path, "has " + std::to_string(hz) + " Hz (5, 10 or 20)");
    m.columns_per_frame = cols;
    m.frequency_hz = hz;
  }

  // Beams.
  const Json::Value& alt = required({{&beam, "beam_altitude_angles", "beam_intrinsics.beam_altitude_angles"},
                                     {&root, "beam_altitude_angles", "beam_altitude_angles"}},
                                    &path);
  m.beam_altitude_deg = rd.numbers(alt, path, 1, 256);
  const Json::Value& az = required({{&beam, "beam_azimuth_angles", "beam_intrinsics.beam_azimuth_angles"},
                                    {&root, "beam_azimuth_angles", "beam_azimuth_angles"}},
                                   &path);
  m.beam_azimuth_deg = rd.numbers(az, path, m.beam_altitude_deg.size(), m.beam_altitude_deg.size());
  for (std::size_t i = 0; i < m.beam_altitude_deg.size(); ++i) {
    if (std::abs(m.beam_altitude_deg[i]) > 90.0 || std::abs(m.beam_azimuth_deg[i]) > 45.0) {
      rd.fail("beam angles", "beam " + std::to_string(i) + " has altitude " + std::to_string(m.beam_altitude_deg[i]) +
                                 "° / azimuth " + std::to_string(m.beam_azimuth_deg[i]) + "° (out of range)");
    }
  }
  m.lidar_origin_to_beam_origin_mm = rd.number(
      required({{&beam, "lidar_origin_to_beam_origin_mm", "beam_intrinsics.lidar_origin_to_beam_origin_mm"},
                {&root, "lidar_origin_to_beam_origin_mm", "lidar_origin_to_beam_origin_mm"}},
               &path),
      path);
  if (m.lidar_origin_to_beam_origin_mm < 0.0 || m.lidar_origin_to_beam_origin_mm > 200.0) {
    rd.fail(path, "is " + std::to_string(m.lidar_origin_to_beam_origin_mm) + " mm (expected 0..200)");
  }
  m.beam_offset_x_mm = m.lidar_origin_to_beam_origin_mm;
  if (const auto* v = lookup({{&beam, "beam_to_lidar_transform", "beam_intrinsics.beam_to_lidar_transform"},
                              {&root, "beam_to_lidar_transform", "beam_to_lidar_transform"}},
                             &path)) {
    const Eigen::Matrix4d T = rd.transform(*v, path);
    m.beam_offset_x_mm = T(0, 3);
    m.beam_offset_z_mm = T(2, 3);
  }

  // Extrinsics.
  m.lidar_to_sensor = rd.transform(required({{&lidar_intr, "lidar_to_sensor_transform", "lidar_intrinsics.lidar_to_sensor_transform"},
                                             {&root, "lidar_to_sensor_transform", "lidar_to_sensor_transform"}},
                                            &path),
                                   path);
  m.imu_to_sensor = rd.transform(required({{&imu_intr, "imu_to_sensor_transform", "imu_intrinsics.imu_to_sensor_transform"},
                                           {&root, "imu_to_sensor_transform", "imu_to_sensor_transform"}},
                                          &path),
                                 path);

  // Packet layout. Without a data format (firmware before 2.0): legacy packets of 16 columns,
  // one pixel per beam, the whole revolution.
  m.pixels_per_column = static_cast<int>(m.beam_altitude_deg.size());
  m.column_window_first = 0;
  m.column_window_last = m.columns_per_frame - 1;
  if (fmt_p) {
    m.columns_per_frame = rd.integer(required({{&fmt, "columns_per_frame", fmt_name + ".columns_per_frame"}}, &path), path,
                                     m.columns_per_frame, m.columns_per_frame);
    m.columns_per_packet = rd.integer(required({{&fmt, "columns_per_packet", fmt_name + ".columns_per_packet"}}, &path), path, 1, 64);
    m.pixels_per_column = rd.integer(required({{&fmt, "pixels_per_column", fmt_name + ".pixels_per_column"}}, &path), path,
                                     m.pixels_per_column, m.pixels_per_column);
    if (const auto* v = lookup({{&fmt, "column_window", fmt_name + ".column_window"}}, &path)) {
      const auto w = rd.numbers(*v, path, 2, 2);
      for (double c : w) {
        if (c < 0 || c >= m.columns_per_frame || c != std::floor(c)) rd.fail(path, "holds a column outside 0.." + std::to_string(m.columns_per_frame - 1));
      }
      m.column_window_first = static_cast<int>(w[0]);
      m.column_window_last = static_cast<int>(w[1]);
    }
  }
  if (m.columns_per_frame % m.columns_per_packet != 0) {
    rd.fail(fmt_name + ".columns_per_packet", "does not divide columns_per_frame");
  }
  const auto* lp = lookup({{&fmt, "udp_profile_lidar", fmt_name + ".udp_profile_lidar"},
                           {&config, "udp_profile_lidar", "config_params.udp_profile_lidar"},
                           {&root, "udp_profile_lidar", "udp_profile_lidar"}},
                          &path);
  if (lp) {
    const std::string p = rd.string(*lp, path);
    if (p == "LEGACY") m.lidar_profile = LidarProfile::kLegacy;
    else if (p == "RNG19_RFL8_SIG16_NIR16") m.lidar_profile = LidarProfile::kRng19Rfl8Sig16Nir16;
    else if (p == "RNG15_RFL8_NIR8") m.lidar_profile = LidarProfile::kRng15Rfl8Nir8;
    else if (p == "RNG19_RFL8_SIG16_NIR16_DUAL") m.lidar_profile = LidarProfile::kRng19Rfl8Sig16Nir16Dual;
    else {
      rd.fail(path, "is '" + p +
                        "', a lidar packet profile not read here (read: LEGACY, RNG19_RFL8_SIG16_NIR16, "
                        "RNG15_RFL8_NIR8, RNG19_RFL8_SIG16_NIR16_DUAL)");
    }
  }
  const auto* ip = lookup({{&fmt, "udp_profile_imu", fmt_name + ".udp_profile_imu"},
                           {&config, "udp_profile_imu", "config_params.udp_profile_imu"},
                           {&root, "udp_profile_imu", "udp_profile_imu"}},
                          &path);
  if (ip && rd.string(*ip, path) != "LEGACY") {
    rd.fail(path, "is '" + ip->asString() + "', an IMU packet profile not read here (read: LEGACY)");
  }
  if (const auto* ht = lookup({{&fmt, "header_type", fmt_name + ".header_type"}}, &path)) {
    if (rd.string(*ht, path) != "STANDARD") rd.fail(path, "is '" + ht->asString() + "' (read: STANDARD)");
  }

  // UDP ports (absent in captures' metadata of old firmware: the sensor defaults).
  if (const auto* v = lookup({{&config, "udp_port_lidar", "config_params.udp_port_lidar"}, {&root, "udp_port_lidar", "udp_port_lidar"}}, &path)) {
    m.udp_port_lidar = static_cast<std::uint16_t>(rd.integer(*v, path, 0, 65535));
  }
  if (const auto* v = lookup({{&config, "udp_port_imu", "config_params.udp_port_imu"}, {&root, "udp_port_imu", "udp_port_imu"}}, &path)) {
    m.udp_port_imu = static_cast<std::uint16_t>(rd.integer(*v, path, 0, 65535));
  }
  return m;
}

Metadata load_metadata(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError("Ouster metadata " + path + ": cannot open the file");
  std::stringstream ss;
  ss << f.rdbuf();
  return parse_metadata(ss.str(), path);
}

}  // namespace fuse::io::ouster

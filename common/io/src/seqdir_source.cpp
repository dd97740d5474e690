#include "fuse/io/seqdir_source.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "fuse/io/time_ns.hpp"

namespace fuse::io {
namespace {

namespace fs = std::filesystem;

constexpr const char* kScansHeader = "idx,t_start,t_end";
constexpr const char* kImuHeader = "timestamp,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z";
constexpr std::size_t kScanColumns = 3, kImuColumns = 7;
/// calib.yaml rotation must be a unit quaternion to this tolerance.
constexpr double kQuaternionNormTolerance = 1e-6;
/// Largest valid ring index (uint16).
constexpr float kMaxRing = 65535.f;

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> fields;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    fields.push_back(line.substr(start, comma - start));
    if (comma == std::string::npos) return fields;
    start = comma + 1;
  }
}

/// One CSV file read line by line; errors name the file and the line.
class CsvFile {
 public:
  CsvFile(const std::string& path, const char* header, std::size_t columns) : path_(path), in_(path), columns_(columns) {
    if (!in_) throw InputError(path + ": cannot open");
    std::string first;
    if (!read_line(first)) fail("empty file, expected the header '" + std::string(header) + "'");
    if (first != header) fail("header '" + first + "', expected '" + header + "'");
  }
  /// Next data row split into fields; false at the end. Blank lines are refused.
  bool next(std::vector<std::string>& fields) {
    std::string line;
    if (!read_line(line)) return false;
    fields = split(line);
    if (fields.size() != columns_) {
      fail(std::to_string(fields.size()) + " columns, expected " + std::to_string(columns_));
    }
    return true;
  }
  double number(const std::string& field, const char* column) const {
    const char* text = field.c_str();
    char* end = nullptr;
    const double v = std::strtod(text, &end);
    if (field.empty() || end != text + field.size()) fail(std::string(column) + " '" + field + "' is not a number");
    return v;  // NaN/inf are parsed here and refused by the validator (counted)
  }
  std::uint64_t integer(const std::string& field, const char* column) const {
    if (field.empty() || field.find_first_not_of("0123456789") != std::string::npos || field.size() > 19) {
      fail(std::string(column) + " '" + field + "' is not a non-negative integer");
    }
    return std::stoull(field);
  }
  std::size_t line() const { return line_; }
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(path_ + " line " + std::to_string(line_) + ": " + what);
  }

 private:
  bool read_line(std::string& line) {
    if (!std::getline(in_, line)) return false;
    ++line_;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  }
  std::string path_;
  std::ifstream in_;
  std::size_t columns_;
  std::size_t line_ = 0;
};

/// imu.csv timestamp: integer nanoseconds (exact), or a number in seconds or nanoseconds.
double parse_timestamp(const CsvFile& csv, const std::string& field) {
  if (!field.empty() && field.find_first_not_of("0123456789") == std::string::npos && field.size() <= 19) {
    const std::uint64_t v = csv.integer(field, "timestamp");
    return static_cast<double>(v) > kNanosecondThreshold ? ns_to_seconds(v) : static_cast<double>(v);
  }
  const double v = csv.number(field, "timestamp");
  return v > kNanosecondThreshold ? v / kNsPerSecond : v;
}

std::vector<double> yaml_numbers(const YAML::Node& node, std::size_t n, const std::string& where) {
  if (!node || !node.IsSequence() || node.size() != n) {
    throw InputError(where + ": expected a list of " + std::to_string(n) + " numbers");
  }
  std::vector<double> out;
  for (const auto& v : node) {
    try {
      out.push_back(v.as<double>());
    } catch (const YAML::Exception&) {
      throw InputError(where + ": '" + YAML::Dump(v) + "' is not a number");
    }
    if (!std::isfinite(out.back())) throw InputError(where + ": non-finite value");
  }
  return out;
}

}  // namespace

Eigen::Isometry3d read_calib_yaml(const std::string& file) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(file);
  } catch (const YAML::Exception& e) {
    throw InputError(file + ": " + e.what());
  }
  const YAML::Node T = root["T_imu_lidar"];
  if (!T || !T.IsMap()) throw InputError(file + ": missing map 'T_imu_lidar'");
  const auto t = yaml_numbers(T["translation"], 3, file + ": T_imu_lidar.translation");
  const auto q = yaml_numbers(T["rotation_xyzw"], 4, file + ": T_imu_lidar.rotation_xyzw");
  Eigen::Quaterniond rotation(q[3], q[0], q[1], q[2]);
  if (std::abs(rotation.norm() - 1.0) > kQuaternionNormTolerance) {
    throw InputError(file + ": T_imu_lidar.rotation_xyzw has norm " + std::to_string(rotation.norm()) + ", expected 1");
  }
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = rotation.normalized().toRotationMatrix();
  out.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
  return out;
}

SeqdirSource::SeqdirSource(const std::string& dir, const TimeGateConfig& clock)
    : dir_(dir), validator_("sequence directory '" + dir + "'", clock, /*interleaved=*/false), max_gap_s_(clock.max_gap_s) {
  if (!fs::is_directory(dir)) throw InputError(dir + ": not a directory");
  read_scans_csv();
  read_imu_csv();
  read_calib();
}

void SeqdirSource::read_scans_csv() {
  CsvFile csv(dir_ + "/scans.csv", kScansHeader, kScanColumns);
  std::vector<std::string> f;
  while (csv.next(f)) {
    ScanEntry e;
    e.index = csv.integer(f[0], "idx");
    e.t_start = csv.number(f[1], "t_start");
    e.t_end = csv.number(f[2], "t_end");
    e.line = csv.line();
    char name[32];
    std::snprintf(name, sizeof name, "raw/%06llu.bin", static_cast<unsigned long long>(e.index));
    e.raw_path = dir_ + "/" + name;
    std::error_code ec;
    const auto size = fs::file_size(e.raw_path, ec);
    if (ec) csv.fail("scan " + std::to_string(e.index) + ": cannot read " + e.raw_path + " (" + ec.message() + ")");
    if (size % kRawPointBytes != 0) {
      csv.fail(e.raw_path + " has " + std::to_string(size) + " bytes, not a multiple of " + std::to_string(kRawPointBytes));
    }
    scans_.push_back(std::move(e));
  }
}

void SeqdirSource::read_imu_csv() {
  CsvFile csv(dir_ + "/imu.csv", kImuHeader, kImuColumns);
  std::vector<std::string> f;
  static const char* const kColumns[] = {"timestamp", "gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"};
  while (csv.next(f)) {
    ImuSample s;
    s.t = parse_timestamp(csv, f[0]);
    for (int i = 0; i < 3; ++i) {
      s.gyro[i] = csv.number(f[1 + i], kColumns[1 + i]);
      s.accel[i] = csv.number(f[4 + i], kColumns[4 + i]);
    }
    s.sequence = imu_.size();
    imu_.push_back(s);
  }
}

void SeqdirSource::read_calib() {
  const std::string file = dir_ + "/calib.yaml";
  if (fs::exists(file)) T_imu_lidar_ = read_calib_yaml(file);
}

LidarScan SeqdirSource::load_scan(const ScanEntry& e) const {
  std::ifstream in(e.raw_path, std::ios::binary | std::ios::ate);
  if (!in) throw InputError(e.raw_path + ": cannot open (scans.csv line " + std::to_string(e.line) + ")");
  std::vector<char> bytes(static_cast<std::size_t>(in.tellg()));
  in.seekg(0);
  if (!in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()))) throw InputError(e.raw_path + ": read error");
  if (bytes.size() % kRawPointBytes != 0) {
    throw InputError(e.raw_path + ": " + std::to_string(bytes.size()) + " bytes, not a multiple of " +
                     std::to_string(kRawPointBytes));
  }
  LidarScan scan;
  scan.t_start = e.t_start;
  scan.t_end = e.t_end;
  scan.sequence = e.index;
  scan.points.resize(bytes.size() / kRawPointBytes);
  for (std::size_t i = 0; i < scan.points.size(); ++i) {
    float v[6];
    std::memcpy(v, bytes.data() + i * kRawPointBytes, kRawPointBytes);
    if (!(v[5] >= 0.f && v[5] <= kMaxRing && v[5] == std::floor(v[5]))) {
      throw InputError(e.raw_path + ": point " + std::to_string(i) + " has ring " + std::to_string(v[5]) +
                       ", expected an integer in 0..65535");
    }
    scan.points[i] = LidarPoint{v[0], v[1], v[2], v[3], v[4], static_cast<std::uint16_t>(v[5])};
  }
  return scan;
}

std::string SeqdirSource::describe() const {
  return "sequence directory '" + dir_ + "' (" + std::to_string(scans_.size()) + " scans, " +
         std::to_string(imu_.size()) + " IMU samples)";
}

void SeqdirSource::fill_streams() {
  // Each file is checked in its own order before the two are merged by time: a stamp that jumps
  // must be judged among its neighbours in the file, not moved by the merge. The merge runs on
  // each stream's continuous time (stamps less the clock steps found before them).
  auto check = [this](SensorEvent e, std::deque<Passed>& passed) {
    std::deque<SensorEvent> out;
    validator_.check(std::move(e), out);
    for (SensorEvent& o : out) {
      const double t = o.kind == SensorEvent::Kind::kImu ? o.imu.t : o.scan.t_end;
      passed.push_back({t, validator_.clock_offset(o.kind), std::move(o)});
    }
  };
  while (imu_passed_.empty() && next_imu_ < imu_.size()) {
    SensorEvent e;
    e.kind = SensorEvent::Kind::kImu;
    e.imu = imu_[next_imu_++];
    check(std::move(e), imu_passed_);
  }
  while (scans_passed_.empty() && next_scan_ < scans_.size()) {
    SensorEvent e;
    e.kind = SensorEvent::Kind::kLidar;
    e.scan = load_scan(scans_[next_scan_++]);
    check(std::move(e), scans_passed_);
  }
  if (next_imu_ == imu_.size() && next_scan_ == scans_.size()) validator_.finish();
}

double SeqdirSource::merge_time(const Passed& p) const {
  if (p.event.kind == SensorEvent::Kind::kImu) return p.t - p.offset;
  const double imu_offset = validator_.clock_offset(SensorEvent::Kind::kImu);
  return p.t - (std::abs(p.offset - imu_offset) <= max_gap_s_ ? imu_offset : p.offset);
}

bool SeqdirSource::next(SensorEvent& out) {
  fill_streams();
  const bool have_imu = !imu_passed_.empty(), have_scan = !scans_passed_.empty();
  if (!have_imu && !have_scan) return false;
  // Arrival order: IMU at t, scan at t_end; on a tie the IMU sample comes first.
  const bool take_imu =
      have_imu && (!have_scan || !(merge_time(imu_passed_.front()) > merge_time(scans_passed_.front())));
  std::deque<Passed>& from = take_imu ? imu_passed_ : scans_passed_;
  out = std::move(from.front().event);
  from.pop_front();
  return true;
}

}  // namespace fuse::io

// Faults injected into a copy of a sequence directory (test/system): imu.csv and scans.csv
// edited line by line, raw/ linked to the original. Used by the time-fault and the multi-process
// tests.
#pragma once

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

namespace fuse::test {

namespace fs = std::filesystem;

using Lines = std::vector<std::string>;

inline Lines read_lines(const fs::path& file) {
  std::ifstream in(file);
  Lines lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

inline void write_lines(const fs::path& file, const Lines& lines) {
  std::ofstream out(file, std::ios::trunc);
  for (const auto& l : lines) out << l << '\n';
}

/// imu.csv: timestamp in ns, then gyro and accel.
inline double imu_time(const std::string& row) { return std::stod(row.substr(0, row.find(','))) * 1e-9; }

inline std::string restamp_imu(const std::string& row, double dt) {
  const auto comma = row.find(',');
  const long long ns = std::stoll(row.substr(0, comma)) + std::llround(dt * 1e9);
  return std::to_string(ns) + row.substr(comma);
}

/// Index (in imu.csv, header at 0) of the first sample after time t.
inline std::size_t first_after(const Lines& imu, double t) {
  for (std::size_t i = 1; i < imu.size(); ++i) {
    if (imu_time(imu[i]) > t) return i;
  }
  return imu.size();
}

/// A copy of the sequence whose imu.csv and scans.csv lines (header first) were edited; raw/ is
/// linked to the original.
inline fs::path faulty_sequence(const std::string& source, const std::string& name,
                                const std::function<void(Lines& imu, Lines& scans)>& edit) {
  const fs::path dir = fs::temp_directory_path() / ("fuse_time_fault_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  fs::copy_file(source + "/calib.yaml", dir / "calib.yaml");
  fs::create_directory_symlink(fs::absolute(source + "/raw"), dir / "raw");
  Lines imu = read_lines(source + "/imu.csv"), scans = read_lines(source + "/scans.csv");
  edit(imu, scans);
  write_lines(dir / "imu.csv", imu);
  write_lines(dir / "scans.csv", scans);
  return dir;
}


}  // namespace fuse::test

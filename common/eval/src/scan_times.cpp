// fuse-run's timing.csv, read back with every row checked.
#include "fuse/eval/scan_times.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace fuse::eval {
namespace {

constexpr double kP95 = 0.95;
constexpr double kP99 = 0.99;

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream in(line);
  std::string field;
  while (std::getline(in, field, ',')) fields.push_back(field);
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

double number(const std::string& text, const std::string& where) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(value)) {
    throw std::runtime_error(where + ": '" + text + "' is not a finite number");
  }
  return value;
}

}  // namespace

ScanTimes read_scan_times(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw std::runtime_error(path + ": cannot open");
  std::string line;
  if (!std::getline(file, line)) throw std::runtime_error(path + ":1: empty file, expected a header");
  const std::vector<std::string> header = split_csv(line);
  const auto column = [&](const std::string& name) {
    const auto it = std::find(header.begin(), header.end(), name);
    if (it == header.end()) throw std::runtime_error(path + ":1: no column '" + name + "' in the header");
    return static_cast<std::size_t>(it - header.begin());
  };
  const std::size_t t_col = column("t");
  const std::size_t ms_col = column("total_ms");
  ScanTimes times;
  for (std::size_t n = 2; std::getline(file, line); ++n) {
    if (line.empty()) continue;
    const std::string where = path + ":" + std::to_string(n);
    const std::vector<std::string> fields = split_csv(line);
    if (fields.size() != header.size()) {
      throw std::runtime_error(where + ": " + std::to_string(fields.size()) + " columns, the header has " +
                               std::to_string(header.size()));
    }
    const double t = number(fields[t_col], where);
    const double ms = number(fields[ms_col], where);
    if (ms < 0.0) throw std::runtime_error(where + ": negative total_ms");
    if (!times.t.empty() && t < times.t.back()) throw std::runtime_error(where + ": scan time goes back");
    times.t.push_back(t);
    times.total_ms.push_back(ms);
  }
  return times;
}

TimeStatistics time_statistics(const std::vector<double>& ms) {
  TimeStatistics s;
  if (ms.empty()) return s;
  std::vector<double> sorted = ms;
  std::sort(sorted.begin(), sorted.end());
  s.mean_ms = std::accumulate(sorted.begin(), sorted.end(), 0.0) / static_cast<double>(sorted.size());
  const auto at = [&](double q) {
    return sorted[std::min(sorted.size() - 1, static_cast<std::size_t>(q * static_cast<double>(sorted.size())))];
  };
  s.median_ms = at(0.5);
  s.p95_ms = at(kP95);
  s.p99_ms = at(kP99);
  s.max_ms = sorted.back();
  return s;
}

}  // namespace fuse::eval

// DIR/point_labels.bin: which points of each scan lie on a moving object. Little-endian:
//   file header: 8 bytes "FSIMLBL1", uint32 number of scans
//   per scan, in recording order: uint64 scan end time (ns, as the recording stamps the scan),
//   uint32 point count, then one byte per point in the scan's point order: 0 static, 1 moving.
// A reader checks the magic, the scan count and that every scan's time and count match the
// recording's scans.
#pragma once

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

namespace fuse::sim {

inline constexpr char kPointLabelsMagic[8] = {'F', 'S', 'I', 'M', 'L', 'B', 'L', '1'};

class PointLabelWriter {
 public:
  /// Creates the file for `scans` scans; throws std::runtime_error when it cannot.
  PointLabelWriter(const std::string& file, std::uint64_t scans);
  /// The next scan's labels (t_end in seconds, converted as the recording does).
  void write(double t_end, const std::vector<std::uint8_t>& labels);
  /// Checks that all announced scans were written and flushes; throws std::runtime_error.
  void close();

 private:
  std::string file_;
  std::ofstream out_;
  std::uint64_t announced_ = 0, written_ = 0;
};

struct ScanLabels {
  std::uint64_t t_end_ns = 0;
  std::vector<std::uint8_t> labels;
};

/// Reads a point_labels.bin; throws std::runtime_error naming what is wrong (magic, truncation,
/// a label other than 0 or 1, trailing bytes, a scan count that does not match).
std::vector<ScanLabels> read_point_labels(const std::string& file);

}  // namespace fuse::sim

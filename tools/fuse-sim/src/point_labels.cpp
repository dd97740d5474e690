#include "fuse/sim/point_labels.hpp"

#include <cstring>
#include <iterator>
#include <stdexcept>

#include "fuse/io/time_ns.hpp"

namespace fuse::sim {

namespace {
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "point_labels.bin is written little-endian");

template <typename T>
void put(std::ofstream& out, T value) {
  out.write(reinterpret_cast<const char*>(&value), sizeof value);
}

template <typename T>
T take(const std::string& bytes, std::size_t& pos, const std::string& file, const char* what) {
  if (bytes.size() - pos < sizeof(T)) throw std::runtime_error(file + ": truncated in " + what);
  T value;
  std::memcpy(&value, bytes.data() + pos, sizeof value);
  pos += sizeof value;
  return value;
}
}  // namespace

PointLabelWriter::PointLabelWriter(const std::string& file, std::uint64_t scans)
    : file_(file), out_(file, std::ios::binary | std::ios::trunc), announced_(scans) {
  if (!out_) throw std::runtime_error(file + ": cannot create");
  if (scans > UINT32_MAX) throw std::runtime_error(file + ": too many scans");
  out_.write(kPointLabelsMagic, sizeof kPointLabelsMagic);
  put<std::uint32_t>(out_, static_cast<std::uint32_t>(scans));
}

void PointLabelWriter::write(double t_end, const std::vector<std::uint8_t>& labels) {
  if (written_ == announced_) throw std::runtime_error(file_ + ": more scans than announced");
  if (labels.size() > UINT32_MAX) throw std::runtime_error(file_ + ": too many points in a scan");
  put<std::uint64_t>(out_, io::seconds_to_ns(t_end));
  put<std::uint32_t>(out_, static_cast<std::uint32_t>(labels.size()));
  out_.write(reinterpret_cast<const char*>(labels.data()), static_cast<std::streamsize>(labels.size()));
  ++written_;
}

void PointLabelWriter::close() {
  out_.flush();
  if (!out_) throw std::runtime_error(file_ + ": cannot write");
  if (written_ != announced_)
    throw std::runtime_error(file_ + ": " + std::to_string(written_) + " scans written of " +
                             std::to_string(announced_) + " announced");
  out_.close();
}

std::vector<ScanLabels> read_point_labels(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error(file + ": cannot open");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() < sizeof kPointLabelsMagic ||
      std::memcmp(bytes.data(), kPointLabelsMagic, sizeof kPointLabelsMagic) != 0)
    throw std::runtime_error(file + ": not a point label file (magic FSIMLBL1 missing)");
  std::size_t pos = sizeof kPointLabelsMagic;
  const std::uint32_t scans = take<std::uint32_t>(bytes, pos, file, "the header");
  std::vector<ScanLabels> out;
  for (std::uint32_t k = 0; k < scans; ++k) {
    const std::string where = "scan " + std::to_string(k);
    ScanLabels s;
    s.t_end_ns = take<std::uint64_t>(bytes, pos, file, where.c_str());
    const std::uint32_t n = take<std::uint32_t>(bytes, pos, file, where.c_str());
    if (bytes.size() - pos < n) throw std::runtime_error(file + ": truncated in the labels of " + where);
    s.labels.assign(bytes.begin() + static_cast<std::ptrdiff_t>(pos),
                    bytes.begin() + static_cast<std::ptrdiff_t>(pos + n));
    pos += n;
    for (std::uint8_t l : s.labels)
      if (l > 1)
        throw std::runtime_error(file + ": label " + std::to_string(l) + " in " + where + " (0 or 1 expected)");
    out.push_back(std::move(s));
  }
  if (pos != bytes.size())
    throw std::runtime_error(file + ": " + std::to_string(bytes.size() - pos) + " bytes after the last scan");
  return out;
}

}  // namespace fuse::sim

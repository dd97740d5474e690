#include "fuse/sim/cloud_reader.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>

namespace fuse::sim {

namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the binary PLY / PCD bodies are read little-endian");

constexpr std::size_t kMaxHeaderBytes = 1 << 16;  // a header longer than this is not a point cloud header
constexpr std::size_t kMaxCountDigits = 19;        // decimal digits of a count (fits in 64 bits)
constexpr std::uint64_t kMaxFieldCount = 1024;     // PCD COUNT of one field (e.g. a descriptor)
constexpr std::size_t kQuotedChars = 40;           // of an unrecognised first line, in the message

[[noreturn]] void fail(const std::string& file, const std::string& what) { throw CloudReadError(file + ": " + what); }

std::vector<std::string> words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> w;
  for (std::string s; in >> s;) w.push_back(s);
  return w;
}

/// A non-negative decimal integer, or fail naming `what`.
std::uint64_t count_of(const std::string& file, const std::string& text, const std::string& what) {
  if (text.empty() || text.size() > kMaxCountDigits || text.find_first_not_of("0123456789") != std::string::npos)
    fail(file, what + ": '" + text + "' is not a non-negative integer");
  return std::stoull(text);
}

/// The header's lines (without line ends) up to and including the line `last` satisfies, and the
/// offset of the body after it.
template <typename IsLast>
std::vector<std::string> header_lines(const std::string& file, const std::string& bytes, IsLast is_last,
                                      std::size_t& body) {
  std::vector<std::string> lines;
  std::size_t pos = 0;
  while (pos < bytes.size() && pos < kMaxHeaderBytes) {
    const std::size_t end = bytes.find('\n', pos);
    if (end == std::string::npos) break;
    std::string line = bytes.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
    pos = end + 1;
    if (is_last(line)) {
      body = pos;
      return lines;
    }
  }
  fail(file, "the header does not end (no end line within the first 64 KiB)");
}

/// Where x, y and z sit in a point record.
struct Layout {
  std::size_t stride = 0;
  std::size_t offset[3] = {0, 0, 0};
  std::size_t size[3] = {0, 0, 0};  ///< 4 (float32) or 8 (float64); 0: not found
};

std::vector<Eigen::Vector3f> decode(const std::string& file, const std::string& bytes, std::size_t body,
                                    std::uint64_t count, const Layout& l, bool exact) {
  for (int a = 0; a < 3; ++a)
    if (l.size[a] == 0) fail(file, std::string("no float field '") + "xyz"[a] + "'");
  const std::size_t available = bytes.size() - body;
  if (l.stride == 0 || count > available / l.stride)
    fail(file, "truncated: " + std::to_string(count) + " points of " + std::to_string(l.stride) +
                   " bytes announced, the body holds " + std::to_string(available) + " bytes");
  if (exact && available != count * l.stride)
    fail(file, std::to_string(available - count * l.stride) + " bytes after the last of " + std::to_string(count) +
                   " points");
  std::vector<Eigen::Vector3f> points(count);
  for (std::uint64_t i = 0; i < count; ++i) {
    const char* record = bytes.data() + body + i * l.stride;
    for (int a = 0; a < 3; ++a) {
      double v;
      if (l.size[a] == 4) {
        float f;
        std::memcpy(&f, record + l.offset[a], 4);
        v = f;
      } else {
        std::memcpy(&v, record + l.offset[a], 8);
      }
      if (!std::isfinite(v)) fail(file, "point " + std::to_string(i) + " has a non-finite coordinate");
      points[i][a] = static_cast<float>(v);
    }
  }
  return points;
}

// Sets x / y / z in the layout when `name` is one of them; fails unless it is a float.
void place(const std::string& file, Layout& l, const std::string& name, bool is_float, std::size_t size) {
  const int axis = name == "x" ? 0 : name == "y" ? 1 : name == "z" ? 2 : -1;
  if (axis < 0) return;
  if (!is_float || (size != 4 && size != 8)) fail(file, "field '" + name + "' must be float32 or float64");
  if (l.size[axis] != 0) fail(file, "field '" + name + "' appears twice");
  l.offset[axis] = l.stride;
  l.size[axis] = size;
}

std::vector<Eigen::Vector3f> read_ply(const std::string& file, const std::string& bytes) {
  std::size_t body = 0;
  const std::vector<std::string> lines = header_lines(
      file, bytes, [](const std::string& s) { return s == "end_header"; }, body);
  static const std::map<std::string, std::size_t> kSizes = {
      {"char", 1},   {"int8", 1},    {"uchar", 1},  {"uint8", 1},  {"short", 2}, {"int16", 2},
      {"ushort", 2}, {"uint16", 2},  {"int", 4},    {"int32", 4},  {"uint", 4},  {"uint32", 4},
      {"float", 4},  {"float32", 4}, {"double", 8}, {"float64", 8}};
  Layout layout;
  std::uint64_t vertices = 0;
  bool format = false, any_element = false, in_vertex = false, seen_vertex = false, after_vertex = false;
  for (std::size_t k = 1; k + 1 < lines.size(); ++k) {
    const std::vector<std::string> w = words(lines[k]);
    if (w.empty() || w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "format") {
      if (w.size() != 3 || w[1] != "binary_little_endian" || w[2] != "1.0")
        fail(file, "PLY '" + lines[k] + "' is not supported (binary_little_endian 1.0 only)");
      format = true;
    } else if (w[0] == "element") {
      if (w.size() != 3) fail(file, "bad PLY element line '" + lines[k] + "'");
      const std::uint64_t n = count_of(file, w[2], "element " + w[1]);
      any_element = true;
      if (w[1] == "vertex") {
        if (seen_vertex) fail(file, "two vertex elements");
        seen_vertex = in_vertex = true;
        vertices = n;
      } else {
        if (!seen_vertex && n > 0) fail(file, "element '" + w[1] + "' before the vertices is not supported");
        after_vertex = after_vertex || n > 0;
        in_vertex = false;
      }
    } else if (w[0] == "property") {
      if (!any_element) fail(file, "a property before any element");
      if (!in_vertex) continue;  // properties of a later element: not read
      if (w.size() >= 2 && w[1] == "list") fail(file, "list property in the vertex element is not supported");
      if (w.size() != 3) fail(file, "bad PLY property line '" + lines[k] + "'");
      const auto size = kSizes.find(w[1]);
      if (size == kSizes.end()) fail(file, "unknown PLY property type '" + w[1] + "'");
      place(file, layout, w[2], w[1] == "float" || w[1] == "float32" || w[1] == "double" || w[1] == "float64",
            size->second);
      layout.stride += size->second;
    } else {
      fail(file, "unknown PLY header line '" + lines[k] + "'");
    }
  }
  if (!format) fail(file, "PLY header without a format line");
  if (!seen_vertex) fail(file, "PLY header without a vertex element");
  return decode(file, bytes, body, vertices, layout, !after_vertex);
}

std::vector<Eigen::Vector3f> read_pcd(const std::string& file, const std::string& bytes) {
  std::size_t body = 0;
  const std::vector<std::string> lines = header_lines(
      file, bytes, [](const std::string& s) { return s.rfind("DATA", 0) == 0; }, body);
  std::map<std::string, std::vector<std::string>> keys;
  for (const std::string& line : lines) {
    const std::vector<std::string> w = words(line);
    if (w.empty() || w[0][0] == '#') continue;
    static const char* kKnown[] = {"VERSION", "FIELDS", "SIZE",      "TYPE",   "COUNT",
                                   "WIDTH",   "HEIGHT", "VIEWPOINT", "POINTS", "DATA"};
    if (std::find(std::begin(kKnown), std::end(kKnown), w[0]) == std::end(kKnown))
      fail(file, "unknown PCD header line '" + line + "'");
    if (keys.count(w[0])) fail(file, "PCD header line " + w[0] + " appears twice");
    keys[w[0]] = std::vector<std::string>(w.begin() + 1, w.end());
  }
  const std::vector<std::string>& data = keys["DATA"];
  if (data.size() != 1 || data[0] != "binary")
    fail(file, "PCD DATA '" + (data.empty() ? std::string() : data[0]) + "' is not supported (binary only)");
  const std::vector<std::string> fields = keys["FIELDS"], sizes = keys["SIZE"], types = keys["TYPE"];
  std::vector<std::string> counts = keys["COUNT"];
  if (fields.empty()) fail(file, "PCD header without FIELDS");
  if (counts.empty()) counts.assign(fields.size(), "1");
  if (sizes.size() != fields.size() || types.size() != fields.size() || counts.size() != fields.size())
    fail(file, "PCD SIZE, TYPE and COUNT must give one value per field of FIELDS");
  Layout layout;
  for (std::size_t f = 0; f < fields.size(); ++f) {
    const std::uint64_t size = count_of(file, sizes[f], "SIZE of " + fields[f]);
    const std::uint64_t count = count_of(file, counts[f], "COUNT of " + fields[f]);
    if ((size != 1 && size != 2 && size != 4 && size != 8) || (types[f] != "F" && types[f] != "I" && types[f] != "U"))
      fail(file,
           "field '" + fields[f] + "' has SIZE " + sizes[f] + " TYPE " + types[f] + " (sizes 1 2 4 8, types F I U)");
    if (count == 0 || count > kMaxFieldCount) fail(file, "field '" + fields[f] + "' has COUNT " + counts[f]);
    if (count != 1 && (fields[f] == "x" || fields[f] == "y" || fields[f] == "z"))
      fail(file, "field '" + fields[f] + "' must have COUNT 1");
    place(file, layout, fields[f], types[f] == "F", size);
    layout.stride += size * count;
  }
  if (keys["POINTS"].size() != 1) fail(file, "PCD header without POINTS");
  const std::uint64_t points = count_of(file, keys["POINTS"][0], "POINTS");
  if (keys.count("WIDTH") && keys.count("HEIGHT") && keys["WIDTH"].size() == 1 && keys["HEIGHT"].size() == 1) {
    const std::uint64_t width = count_of(file, keys["WIDTH"][0], "WIDTH");
    const std::uint64_t height = count_of(file, keys["HEIGHT"][0], "HEIGHT");
    if (height == 0 || width > UINT64_MAX / height || width * height != points)
      fail(file, "PCD WIDTH x HEIGHT (" + std::to_string(width) + " x " + std::to_string(height) + ") is not POINTS (" +
                     std::to_string(points) + ")");
  }
  return decode(file, bytes, body, points, layout, true);
}

}  // namespace

std::vector<Eigen::Vector3f> read_cloud(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) fail(file, std::string("cannot open: ") + std::strerror(errno));
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) fail(file, "cannot read");
  if (bytes.empty()) fail(file, "empty file");
  const std::string first = bytes.substr(0, bytes.find('\n'));
  if (first == "ply" || first == "ply\r") return read_ply(file, bytes);
  if (first.rfind("#", 0) == 0 || first.rfind("VERSION", 0) == 0 || first.rfind("FIELDS", 0) == 0)
    return read_pcd(file, bytes);
  fail(file, "neither a PLY nor a PCD file (first line '" + first.substr(0, kQuotedChars) + "')");
}

}  // namespace fuse::sim

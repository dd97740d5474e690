#include "fuse/rosbag/bz2.hpp"

#include <bzlib.h>

#include <algorithm>
#include <limits>

#include "fuse/io/compression.hpp"
#include "fuse/io/sensor_source.hpp"

namespace fuse::rosbag {

namespace {
[[noreturn]] void fail(const std::string& context, const std::string& what) {
  throw io::InputError(context + ": " + what);
}
}  // namespace

std::vector<std::uint8_t> bz2_decompress(const std::uint8_t* data, std::size_t size, std::uint64_t uncompressed_size,
                                         const std::string& context) {
  if (uncompressed_size > io::kMaxUncompressedChunkBytes) {
    fail(context, "declared uncompressed size " + std::to_string(uncompressed_size) + " is implausible");
  }
  if (size > std::numeric_limits<unsigned>::max()) fail(context, "bz2 input larger than 4 GiB");
  bz_stream s{};
  if (BZ2_bzDecompressInit(&s, 0, 0) != BZ_OK) fail(context, "bz2: cannot initialise the decoder");
  struct End {
    bz_stream* s;
    ~End() { BZ2_bzDecompressEnd(s); }
  } end{&s};
  std::vector<std::uint8_t> out;
  s.next_in = const_cast<char*>(reinterpret_cast<const char*>(data));
  s.avail_in = static_cast<unsigned>(size);
  std::size_t produced = 0;
  for (;;) {
    // Grow in steps of at most 1 MiB beyond what was produced, plus one byte to see overruns.
    const std::size_t want = static_cast<std::size_t>(
        std::min<std::uint64_t>(uncompressed_size + 1, produced + std::max<std::size_t>(produced, 1u << 16)));
    out.resize(std::max(want, produced + 1));
    s.next_out = reinterpret_cast<char*>(out.data() + produced);
    s.avail_out = static_cast<unsigned>(out.size() - produced);
    const int rc = BZ2_bzDecompress(&s);
    produced = out.size() - s.avail_out;
    if (rc == BZ_STREAM_END) break;
    if (rc != BZ_OK) fail(context, "bz2 data is corrupt (libbz2 error " + std::to_string(rc) + ")");
    if (produced > uncompressed_size) break;
    if (s.avail_in == 0 && s.avail_out != 0) fail(context, "bz2 stream is truncated");
  }
  if (produced != uncompressed_size) {
    fail(context, "bz2 data decompresses to " + std::string(produced > uncompressed_size ? "more than " : "") +
                      std::to_string(produced) + " bytes, declared " + std::to_string(uncompressed_size));
  }
  out.resize(produced);
  return out;
}

}  // namespace fuse::rosbag

#include "fuse/io/compression.hpp"

#include <lz4frame.h>
#include <zstd.h>

#include <algorithm>
#include <memory>
#include <stdexcept>

#include "fuse/io/sensor_source.hpp"

namespace fuse::io {
namespace {

/// Zstandard level 3: the library default, a good speed/ratio balance for point clouds.
constexpr int kZstdLevel = 3;
/// First output allocation for a streaming decode; the buffer then doubles up to the declared size.
constexpr std::size_t kInitialOutputBytes = 1u << 16;

[[noreturn]] void fail(const std::string& context, const std::string& what) {
  throw InputError(context + ": " + what);
}

/// Sizes `out` for a new decode: what it already holds (a buffer reused from the last chunk
/// decodes into its capacity without allocating), capped at the declared size.
void start_output(std::vector<std::uint8_t>& out, std::uint64_t expected) {
  out.resize(static_cast<std::size_t>(std::min<std::uint64_t>(out.capacity(), expected)));
}

/// Grows `out` (doubling, capped at `limit`) when the decoder has filled it.
void grow(std::vector<std::uint8_t>& out, std::uint64_t limit) {
  const std::size_t next = std::max<std::size_t>(kInitialOutputBytes, out.size() * 2);
  out.resize(static_cast<std::size_t>(std::min<std::uint64_t>(next, limit)));
}

void zstd_decompress(const std::uint8_t* data, std::size_t size, std::uint64_t expected, const std::string& context,
                     std::vector<std::uint8_t>& out) {
  std::unique_ptr<ZSTD_DCtx, decltype(&ZSTD_freeDCtx)> dctx(ZSTD_createDCtx(), &ZSTD_freeDCtx);
  if (!dctx) throw std::bad_alloc();
  start_output(out, expected);
  ZSTD_inBuffer in{data, size, 0};
  std::size_t produced = 0;
  for (;;) {
    if (produced == out.size()) {
      if (out.size() >= expected) fail(context, "zstd frame incomplete or larger than the declared " + std::to_string(expected) + " bytes");
      grow(out, expected);
    }
    ZSTD_outBuffer ob{out.data(), out.size(), produced};
    const std::size_t before_in = in.pos;
    const std::size_t ret = ZSTD_decompressStream(dctx.get(), &ob, &in);
    if (ZSTD_isError(ret)) fail(context, std::string("zstd: ") + ZSTD_getErrorName(ret));
    const bool progress = ob.pos != produced || in.pos != before_in;
    produced = ob.pos;
    if (ret == 0 && in.pos == in.size) break;  // last frame complete, all input used
    if (!progress && produced < out.size()) fail(context, "zstd data is truncated");
  }
  if (produced != expected) {
    fail(context, "zstd data decompresses to " + std::to_string(produced) + " bytes, declared " + std::to_string(expected));
  }
  out.resize(produced);
}

void lz4_decompress(const std::uint8_t* data, std::size_t size, std::uint64_t expected, const std::string& context,
                    std::vector<std::uint8_t>& out) {
  LZ4F_dctx* raw = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) throw std::bad_alloc();
  std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> dctx(raw, &LZ4F_freeDecompressionContext);
  start_output(out, expected);
  std::size_t consumed = 0, produced = 0;
  for (;;) {
    if (produced == out.size()) {
      if (out.size() >= expected) fail(context, "lz4 frame incomplete or larger than the declared " + std::to_string(expected) + " bytes");
      grow(out, expected);
    }
    std::size_t dst_size = out.size() - produced;
    std::size_t src_size = size - consumed;
    const std::size_t hint = LZ4F_decompress(dctx.get(), out.data() + produced, &dst_size, data + consumed, &src_size, nullptr);
    if (LZ4F_isError(hint)) fail(context, std::string("lz4: ") + LZ4F_getErrorName(hint));
    consumed += src_size;
    produced += dst_size;
    if (hint == 0 && consumed == size) break;  // frame complete, all input used
    if (src_size == 0 && dst_size == 0 && produced < out.size()) fail(context, "lz4 frame is truncated");
  }
  if (produced != expected) {
    fail(context, "lz4 data decompresses to " + std::to_string(produced) + " bytes, declared " + std::to_string(expected));
  }
  out.resize(produced);
}

}  // namespace

const char* compression_name(Compression c) {
  switch (c) {
    case Compression::kZstd: return "zstd";
    case Compression::kLz4: return "lz4";
    case Compression::kNone: break;
  }
  return "";
}

std::vector<std::uint8_t> compress(Compression c, const std::uint8_t* data, std::size_t size) {
  std::vector<std::uint8_t> out;
  compress_into(c, data, size, out);
  return out;
}

void compress_into(Compression c, const std::uint8_t* data, std::size_t size, std::vector<std::uint8_t>& out) {
  if (c == Compression::kZstd) {
    out.resize(ZSTD_compressBound(size));
    const std::size_t n = ZSTD_compress(out.data(), out.size(), data, size, kZstdLevel);
    if (ZSTD_isError(n)) throw std::runtime_error(std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
    out.resize(n);
  } else if (c == Compression::kLz4) {
    LZ4F_preferences_t prefs{};
    prefs.frameInfo.contentSize = size;  // lets readers know the size up front
    out.resize(LZ4F_compressFrameBound(size, &prefs));
    const std::size_t n = LZ4F_compressFrame(out.data(), out.size(), data, size, &prefs);
    if (LZ4F_isError(n)) throw std::runtime_error(std::string("lz4 compression failed: ") + LZ4F_getErrorName(n));
    out.resize(n);
  } else {
    out.assign(data, data + size);
  }
}

void decompress_into(const std::string& name, const std::uint8_t* data, std::size_t size, std::uint64_t uncompressed_size,
                     const std::string& context, std::vector<std::uint8_t>& out) {
  if (uncompressed_size > kMaxUncompressedChunkBytes) {
    fail(context, "declared uncompressed size " + std::to_string(uncompressed_size) + " exceeds the limit of " +
                      std::to_string(kMaxUncompressedChunkBytes) + " bytes");
  }
  if (name.empty()) {
    if (size != uncompressed_size) {
      fail(context, "uncompressed chunk holds " + std::to_string(size) + " bytes, declared " + std::to_string(uncompressed_size));
    }
    out.assign(data, data + size);
    return;
  }
  if (uncompressed_size == 0) {
    if (size != 0) fail(context, "compressed data present but declared uncompressed size is 0");
    out.clear();
    return;
  }
  if (name == "zstd") return zstd_decompress(data, size, uncompressed_size, context, out);
  if (name == "lz4") return lz4_decompress(data, size, uncompressed_size, context, out);
  fail(context, "unsupported compression '" + name + "' (supported: zstd, lz4, none)");
}

std::vector<std::uint8_t> decompress(const std::string& name, const std::uint8_t* data, std::size_t size,
                                     std::uint64_t uncompressed_size, const std::string& context) {
  std::vector<std::uint8_t> out;
  decompress_into(name, data, size, uncompressed_size, context, out);
  return out;
}

}  // namespace fuse::io

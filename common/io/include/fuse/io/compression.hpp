// Chunk compression for MCAP: "zstd" (Zstandard frame), "lz4" (LZ4 frame format, as the MCAP
// spec requires, not the raw block format) or "" (none).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "fuse/io/recording.hpp"

namespace fuse::io {

/// Largest uncompressed chunk a reader accepts; a bigger declared size is treated as corruption.
inline constexpr std::uint64_t kMaxUncompressedChunkBytes = 1ull << 31;

/// MCAP compression name of `c`: "", "zstd" or "lz4".
const char* compression_name(Compression c);

std::vector<std::uint8_t> compress(Compression c, const std::uint8_t* data, std::size_t size);
/// The same into `out`, whose capacity is reused from call to call.
void compress_into(Compression c, const std::uint8_t* data, std::size_t size, std::vector<std::uint8_t>& out);

/// Decompresses `size` bytes compressed with `name` into exactly `uncompressed_size` bytes.
/// The output grows with what the decoder really produces (never pre-allocated from the declared
/// size alone). Unknown compression, corrupt data or a size mismatch -> InputError naming `context`.
std::vector<std::uint8_t> decompress(const std::string& name, const std::uint8_t* data, std::size_t size,
                                     std::uint64_t uncompressed_size, const std::string& context);
/// The same into `out`, whose capacity is reused (a reader decoding chunk after chunk into one
/// buffer allocates, and faults its pages in, only for the largest). On an error `out` holds
/// nothing meaningful.
void decompress_into(const std::string& name, const std::uint8_t* data, std::size_t size, std::uint64_t uncompressed_size,
                     const std::string& context, std::vector<std::uint8_t>& out);

}  // namespace fuse::io

// bzip2 decompression of ROS 1 bag chunks (compression "bz2": one bzip2 stream per chunk).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace fuse::rosbag {

/// Decompresses one bzip2 stream into exactly `uncompressed_size` bytes. The output grows with
/// what the decoder produces (never allocated from the declared size alone). Corrupt or truncated
/// data, or a size mismatch -> fuse::io::InputError naming `context`.
std::vector<std::uint8_t> bz2_decompress(const std::uint8_t* data, std::size_t size, std::uint64_t uncompressed_size,
                                         const std::string& context);

}  // namespace fuse::rosbag

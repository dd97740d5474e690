// Shared by the bag fuzz targets: the readers take a path, so each input is written to a
// per-process scratch file first (tmpfs when available).
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "fuse/core/logging.hpp"

namespace fuse::fuzz {

/// Silences the readers' warnings (salvage mode etc.): logging every input would dominate.
inline void quiet() {
  static const bool done = (fuse::set_log_level("off"), true);
  (void)done;
}

inline std::string scratch_file(const std::uint8_t* data, std::size_t size, const char* extension) {
  static const std::string dir = [] {
    const char* shm = "/dev/shm";
    return std::string(access(shm, W_OK) == 0 ? shm : "/tmp");
  }();
  const std::string path = dir + "/fuse_fuzz_" + std::to_string(getpid()) + extension;
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) std::abort();
  if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  return path;
}

inline void require(bool ok) {
  if (!ok) std::abort();  // an invariant broke: libFuzzer reports the input
}

}  // namespace fuse::fuzz

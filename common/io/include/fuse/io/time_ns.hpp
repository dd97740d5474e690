// Conversion between the estimator's seconds (double) and MCAP timestamps (uint64 nanoseconds).
#pragma once

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace fuse::io {

inline constexpr double kNsPerSecond = 1e9;
/// Largest time representable as uint64 nanoseconds (about 584 years), kept a little below 2^64.
inline constexpr double kMaxTimestampSeconds = 1.8e10;

/// Rounds to the nearest nanosecond; negative, non-finite or too large -> std::invalid_argument.
inline std::uint64_t seconds_to_ns(double t) {
  if (!std::isfinite(t) || t < 0.0 || t > kMaxTimestampSeconds) {
    throw std::invalid_argument("time " + std::to_string(t) + " s cannot be stored as an MCAP timestamp");
  }
  return static_cast<std::uint64_t>(std::llround(t * kNsPerSecond));
}

/// Whole seconds and the remainder are converted separately to keep sub-microsecond precision.
inline double ns_to_seconds(std::uint64_t ns) {
  constexpr std::uint64_t kNs = 1'000'000'000ull;
  return static_cast<double>(ns / kNs) + static_cast<double>(ns % kNs) / kNsPerSecond;
}

}  // namespace fuse::io

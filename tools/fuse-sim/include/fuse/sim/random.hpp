// Deterministic random numbers for the simulator. std::mt19937_64 is specified bit-exactly by the
// standard, but std::normal_distribution / std::uniform_real_distribution are not, so the
// conversions to uniform and normal variates are written here (same seed -> same bytes anywhere).
#pragma once

#include <cstdint>
#include <random>

namespace fuse::sim {

/// Independent random streams derived from one seed (world, motion, IMU noise, LiDAR noise, the
/// vehicle vibration's parameters and its road noise, the moving objects).
enum class Stream : std::uint64_t {
  kWorld = 1,
  kMotion = 2,
  kImu = 3,
  kLidar = 4,
  kVibration = 5,
  kRoadNoise = 6,
  kTraffic = 7,
};

class Rng {
 public:
  /// Seeds a mt19937_64 from (seed, stream) through SplitMix64 so streams do not overlap.
  Rng(std::uint64_t seed, Stream stream);

  /// Uniform in [0, 1): the top 53 bits of one engine output.
  double uniform();
  /// Uniform in [lo, hi).
  double uniform(double lo, double hi);
  /// Standard normal by the Box-Muller transform (the second variate of each pair is cached).
  double normal();
  /// Normal with the given standard deviation and zero mean.
  double normal(double sigma) { return sigma * normal(); }
  /// Uniform integer in [lo, hi] (inclusive), by rejection-free scaling of uniform().
  int uniform_int(int lo, int hi);

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

}  // namespace fuse::sim

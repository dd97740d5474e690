#include "fuse/sim/random.hpp"

#include <cmath>

namespace fuse::sim {

namespace {
// SplitMix64 (Steele, Lea, Flood 2014): a bijective mixer, used to spread (seed, stream) apart.
std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}
constexpr double kTwoPow53 = 9007199254740992.0;  // 2^53: resolution of a double mantissa
constexpr double kTwoPi = 6.283185307179586476925286766559;
}  // namespace

Rng::Rng(std::uint64_t seed, Stream stream)
    : engine_(splitmix64(splitmix64(seed) ^ static_cast<std::uint64_t>(stream))) {}

double Rng::uniform() { return static_cast<double>(engine_() >> 11) / kTwoPow53; }

double Rng::uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

int Rng::uniform_int(int lo, int hi) {
  const double span = static_cast<double>(hi) - static_cast<double>(lo) + 1.0;
  const int k = lo + static_cast<int>(std::floor(uniform() * span));
  return k > hi ? hi : k;
}

double Rng::normal() {
  // Box-Muller: z0 = sqrt(-2 ln u1) cos(2 pi u2), z1 = sqrt(-2 ln u1) sin(2 pi u2), u1 in (0, 1].
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  const double u1 = 1.0 - uniform();
  const double u2 = uniform();
  const double r = std::sqrt(-2.0 * std::log(u1));
  spare_ = r * std::sin(kTwoPi * u2);
  has_spare_ = true;
  return r * std::cos(kTwoPi * u2);
}

}  // namespace fuse::sim

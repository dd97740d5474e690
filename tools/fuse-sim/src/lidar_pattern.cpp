#include "fuse/sim/lidar_pattern.hpp"

#include <cmath>
#include <stdexcept>

namespace fuse::sim {

namespace {
constexpr double kTwoPi = 6.283185307179586476925286766559;
constexpr double kDeg = 0.017453292519943295;
}  // namespace

LidarConfig LidarConfig::mid360() { return LidarConfig{}; }

LidarConfig LidarConfig::spinning32() {
  LidarConfig c;
  c.type = LidarType::kSpinning32;
  c.name = "spinning32";
  c.blind_range_m = 0.3;     // typical for mechanical spinning units
  c.max_range_m = 100.0;
  c.elevation_min_deg = -16.0;
  c.elevation_max_deg = 15.0;
  c.beams = 32;
  c.columns = 1800;
  return c;
}

LidarConfig LidarConfig::spinning64() {
  // An Ouster OS1-64-like unit: 45 deg vertical field of view centred on the horizon, 1024 columns
  // at 10 Hz, 120 m range.
  LidarConfig c;
  c.type = LidarType::kSpinning64;
  c.name = "spinning64";
  c.blind_range_m = 0.3;
  c.max_range_m = 120.0;
  c.elevation_min_deg = -22.5;
  c.elevation_max_deg = 22.5;
  c.beams = 64;
  c.columns = 1024;
  return c;
}

const std::vector<std::string>& LidarConfig::names() {
  static const std::vector<std::string> n = {"mid360", "spinning32", "spinning64"};
  return n;
}

LidarConfig LidarConfig::from_name(const std::string& name) {
  if (name == "mid360") return mid360();
  if (name == "spinning32") return spinning32();
  if (name == "spinning64") return spinning64();
  throw std::invalid_argument("unknown LiDAR model '" + name + "' (expected mid360, spinning32 or spinning64)");
}

int LidarConfig::shots_per_frame() const {
  if (spinning()) return beams * columns;
  return static_cast<int>(std::lround(point_rate_hz * frame_period_s));
}

Eigen::Vector3d direction(double azimuth, double elevation) {
  const double ce = std::cos(elevation);
  return {ce * std::cos(azimuth), ce * std::sin(azimuth), std::sin(elevation)};
}

namespace {

void mid360_shots(const LidarConfig& c, std::uint64_t frame, std::vector<Shot>& shots) {
  const int n = c.shots_per_frame();
  const double el_mid = 0.5 * (c.elevation_max_deg + c.elevation_min_deg) * kDeg;
  const double el_amp = 0.5 * (c.elevation_max_deg - c.elevation_min_deg) * kDeg;
  shots.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    // Global shot index keeps the pattern running across frames (no per-frame restart).
    const std::uint64_t global = frame * static_cast<std::uint64_t>(n) + static_cast<std::uint64_t>(i);
    const int line = static_cast<int>(global % static_cast<std::uint64_t>(c.lines));
    const double tau = static_cast<double>(global) / c.point_rate_hz;
    // Phases reduced modulo one turn before scaling keeps full precision over long runs.
    const double az_turns = std::fmod(c.azimuth_rev_hz * tau, 1.0) + static_cast<double>(line) / c.lines;
    const double el_turns = std::fmod(c.elevation_osc_hz * tau, 1.0) + 0.5 * line / c.lines;
    Shot& s = shots[static_cast<std::size_t>(i)];
    s.t_rel = static_cast<float>(i / c.point_rate_hz);
    s.ring = static_cast<std::uint16_t>(line);
    s.azimuth = kTwoPi * az_turns;
    s.elevation = el_mid + el_amp * std::cos(kTwoPi * el_turns);
    s.dir = direction(s.azimuth, s.elevation);
  }
}

void spinning_shots(const LidarConfig& c, std::vector<Shot>& shots) {
  shots.resize(static_cast<std::size_t>(c.beams) * static_cast<std::size_t>(c.columns));
  const double el_step = (c.elevation_max_deg - c.elevation_min_deg) / (c.beams - 1);
  std::size_t k = 0;
  for (int col = 0; col < c.columns; ++col) {
    const double az = kTwoPi * col / c.columns;
    const float t_rel = static_cast<float>(c.frame_period_s * col / c.columns);
    for (int b = 0; b < c.beams; ++b, ++k) {
      shots[k].t_rel = t_rel;
      shots[k].ring = static_cast<std::uint16_t>(b);
      shots[k].azimuth = az;
      shots[k].elevation = (c.elevation_min_deg + b * el_step) * kDeg;
      shots[k].dir = direction(az, shots[k].elevation);
    }
  }
}

}  // namespace

void generate_shots(const LidarConfig& c, std::uint64_t frame_index, std::vector<Shot>& shots) {
  if (c.spinning())
    spinning_shots(c, shots);
  else
    mid360_shots(c, frame_index, shots);
}

}  // namespace fuse::sim

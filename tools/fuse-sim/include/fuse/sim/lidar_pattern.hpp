// LiDAR scan patterns: the firing time, line (ring) and nominal direction of every shot in a frame.
//  - Mid-360-like: 4 lines fired in turn at 200 kHz; each line sweeps the azimuth continuously and
//    oscillates in elevation over [-7, 52] deg at a frequency incommensurate with the azimuth
//    rate, so successive revolutions and frames fall between each other (non-repetitive rosette).
//  - Spinning 32-beam: uniform elevations, 1800 columns per 0.1 s revolution, every beam of a
//    column fired at the column's time.
//  - Spinning 64-beam (Ouster OS1-64-like): 64 uniform elevations over -22.5..+22.5 deg, 1024
//    columns per 0.1 s revolution, fired like the 32-beam unit.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace fuse::sim {

enum class LidarType { kMid360, kSpinning32, kSpinning64 };

struct LidarConfig {
  LidarType type = LidarType::kMid360;
  std::string name = "mid360";
  double frame_period_s = 0.1;        ///< 10 Hz frames
  double blind_range_m = 0.1;         ///< no return closer than this
  double max_range_m = 40.0;          ///< no return beyond this
  double range_noise_sigma_m = 0.02;  ///< Gaussian range noise
  double angular_noise_sigma_rad = 0.03 * 0.017453292519943295;  ///< beam direction jitter per axis
  // Mid-360 pattern
  double point_rate_hz = 200000.0;
  int lines = 4;
  double elevation_min_deg = -7.0, elevation_max_deg = 52.0;
  double azimuth_rev_hz = 171.37;       ///< revolutions per second of each line's azimuth sweep
  double elevation_osc_hz = 4997.31;    ///< elevation oscillations per second (ratio not rational)
  // Spinning pattern
  int beams = 32;
  int columns = 1800;

  static LidarConfig mid360();
  static LidarConfig spinning32();
  static LidarConfig spinning64();
  /// "mid360", "spinning32" or "spinning64"; throws std::invalid_argument naming the accepted values.
  static LidarConfig from_name(const std::string& name);
  /// The accepted model names, in the order of the help text.
  static const std::vector<std::string>& names();
  int shots_per_frame() const;
  /// A mechanical spinning unit (beams x columns per revolution) rather than the Mid-360 rosette.
  bool spinning() const { return type != LidarType::kMid360; }
};

/// One shot: time since the frame start, line index and unit direction in the LiDAR frame.
struct Shot {
  float t_rel = 0.f;
  std::uint16_t ring = 0;
  Eigen::Vector3d dir = Eigen::Vector3d::UnitX();
  double azimuth = 0.0, elevation = 0.0;  ///< radians; dir = direction(azimuth, elevation)
};

/// Fills `shots` with the nominal shots of frame `frame_index` (frames count from 0).
void generate_shots(const LidarConfig& config, std::uint64_t frame_index, std::vector<Shot>& shots);

/// Unit direction from azimuth (about z, from x) and elevation (from the xy plane).
Eigen::Vector3d direction(double azimuth, double elevation);

}  // namespace fuse::sim

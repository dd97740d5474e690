#include "fuse/io/ouster_scan_assembler.hpp"

#include <algorithm>
#include <cmath>

namespace fuse::io::ouster {

ScanAssembler::ScanAssembler(const Metadata& meta) : meta_(meta) {
  const std::size_t beams = meta_.beam_altitude_deg.size();
  for (std::size_t i = 0; i < beams; ++i) {
    const double phi = 2.0 * M_PI * meta_.beam_altitude_deg[i] / 360.0;
    cos_alt_.push_back(std::cos(phi));
    sin_alt_.push_back(std::sin(phi));
    az_.push_back(-2.0 * M_PI * meta_.beam_azimuth_deg[i] / 360.0);
  }
  for (int m = 0; m < meta_.columns_per_frame; ++m) {
    const double theta = 2.0 * M_PI * (1.0 - static_cast<double>(m) / meta_.columns_per_frame);
    cos_enc_.push_back(std::cos(theta));
    sin_enc_.push_back(std::sin(theta));
  }
  n_ = std::hypot(meta_.beam_offset_x_mm, meta_.beam_offset_z_mm);
  R_ = meta_.lidar_to_sensor.topLeftCorner<3, 3>();
  t_mm_ = meta_.lidar_to_sensor.topRightCorner<3, 1>();
  seen_.assign(static_cast<std::size_t>(meta_.columns_per_frame), 0);
}

Eigen::Vector3d ScanAssembler::point(int m, int beam, std::uint32_t range_mm) const {
  const auto b = static_cast<std::size_t>(beam);
  const auto mi = static_cast<std::size_t>(m);
  const double r = static_cast<double>(range_mm) - n_;
  const double theta = 2.0 * M_PI * (1.0 - static_cast<double>(m) / meta_.columns_per_frame) + az_[b];
  const Eigen::Vector3d p_lidar(r * std::cos(theta) * cos_alt_[b] + meta_.beam_offset_x_mm * cos_enc_[mi],
                                r * std::sin(theta) * cos_alt_[b] + meta_.beam_offset_x_mm * sin_enc_[mi],
                                r * sin_alt_[b] + meta_.beam_offset_z_mm);
  return (R_ * p_lidar + t_mm_) * 1e-3;
}

void ScanAssembler::start(std::uint16_t frame_id) {
  active_ = true;
  emitted_ = false;
  frame_id_ = frame_id;
  columns_ = 0;
  std::fill(seen_.begin(), seen_.end(), 0);
  raw_.clear();
  t_min_ns_ = UINT64_MAX;
  t_max_ns_ = 0;
  empty_in_frame_ = 0;
}

void ScanAssembler::add(const LidarPacket& packet, std::vector<LidarScan>& scans, std::vector<Dropped>& dropped) {
  if (!active_ || packet.frame_id != frame_id_) {
    if (active_ && !emitted_ && columns_ > 0) dropped.push_back({frame_id_, columns_, meta_.window_columns()});
    start(packet.frame_id);
  }
  if (emitted_) return;  // the rest of a full frame: columns outside the window
  const auto ppc = static_cast<std::size_t>(meta_.pixels_per_column);
  for (std::size_t c = 0; c < packet.columns.size(); ++c) {
    const Column& col = packet.columns[c];
    if (!col.valid || !meta_.in_window(col.measurement_id) || seen_[col.measurement_id]) continue;
    seen_[col.measurement_id] = 1;
    ++columns_;
    t_min_ns_ = std::min(t_min_ns_, col.timestamp_ns);
    t_max_ns_ = std::max(t_max_ns_, col.timestamp_ns);
    for (std::size_t b = 0; b < ppc; ++b) {
      const Pixel& px = packet.pixels[c * ppc + b];
      if (px.range_mm == 0) {
        ++empty_in_frame_;
        continue;
      }
      const Eigen::Vector3d p = point(col.measurement_id, static_cast<int>(b), px.range_mm);
      raw_.push_back({static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()),
                      static_cast<float>(px.reflectivity), col.timestamp_ns, static_cast<std::uint16_t>(b)});
    }
  }
  if (columns_ < meta_.window_columns()) return;
  LidarScan scan;
  scan.t_start = static_cast<double>(t_min_ns_) * 1e-9;
  scan.t_end = static_cast<double>(t_max_ns_) * 1e-9;
  scan.sequence = sequence_++;
  scan.points.reserve(raw_.size());
  for (const Raw& r : raw_) {
    LidarPoint p;
    p.x = r.x;
    p.y = r.y;
    p.z = r.z;
    p.intensity = r.intensity;
    p.t_rel = static_cast<float>(static_cast<double>(r.t_ns - t_min_ns_) * 1e-9);
    p.ring = r.ring;
    scan.points.push_back(p);
  }
  empty_returns_ += empty_in_frame_;
  scans.push_back(std::move(scan));
  emitted_ = true;
  raw_.clear();
}

void ScanAssembler::flush(std::vector<Dropped>& dropped) {
  if (active_ && !emitted_ && columns_ > 0) dropped.push_back({frame_id_, columns_, meta_.window_columns()});
  active_ = false;
}

}  // namespace fuse::io::ouster

#include "fuse/io/ouster_pcap_source.hpp"

#include "fuse/core/logging.hpp"

namespace fuse::io {

ouster::Metadata load_ouster_metadata(const std::string& path, std::optional<std::uint16_t> lidar_port,
                                      std::optional<std::uint16_t> imu_port) {
  ouster::Metadata meta = ouster::load_metadata(path);
  if (lidar_port) meta.udp_port_lidar = *lidar_port;
  if (imu_port) meta.udp_port_imu = *imu_port;
  if (meta.udp_port_lidar == 0 && meta.udp_port_imu == 0 && !lidar_port && !imu_port) {
    throw InputError("Ouster metadata " + path + ": neither a lidar nor an IMU UDP port (both 0)");
  }
  // The services take the extrinsic from the config (estimator.extrinsic): say what it is here.
  const Eigen::Isometry3d T = meta.T_imu_sensor();
  const Eigen::Quaterniond q(T.linear());
  logger("ouster")->info(
      "scans are in the sensor frame; from the metadata, estimator.extrinsic (T_imu_lidar) is translation [{:.6f}, "
      "{:.6f}, {:.6f}] rotation_xyzw [{:.6f}, {:.6f}, {:.6f}, {:.6f}]",
      T.translation().x(), T.translation().y(), T.translation().z(), q.x(), q.y(), q.z(), q.w());
  return meta;
}

OusterPcapSource::OusterPcapSource(const OusterPcapConfig& config)
    : config_(config),
      meta_(load_ouster_metadata(config.metadata, config.lidar_port, config.imu_port)),
      validator_("Ouster pcap " + config.pcap) {
  // First pass: which senders are this sensor's (for IMU packets on shared ports).
  stream_ = std::make_unique<ouster::Stream>(meta_, validator_);
  {
    pcap::PcapReader scan(config_.pcap);
    pcap::UdpDatagram d;
    while (scan.next(d)) stream_->learn(d.payload.data(), d.payload.size(), d.src_ip, d.dst_port);
  }
  reader_ = std::make_unique<pcap::PcapReader>(config_.pcap);
  logger("ouster")->info("replaying {}: {} {} ({}), {} x {} columns at {} Hz, profile {}, lidar port {}, IMU port {}",
                         config_.pcap, meta_.prod_line.empty() ? "Ouster" : meta_.prod_line, meta_.serial,
                         config_.metadata, meta_.pixels_per_column, meta_.window_columns(), meta_.frequency_hz,
                         ouster::profile_name(meta_.lidar_profile), meta_.udp_port_lidar, meta_.udp_port_imu);
}

std::string OusterPcapSource::describe() const {
  return "Ouster pcap " + config_.pcap + " (metadata " + config_.metadata + ")";
}

bool OusterPcapSource::next(SensorEvent& out) {
  for (;;) {
    if (!passed_.empty()) {
      out = std::move(passed_.front());
      passed_.pop_front();
      return true;
    }
    if (!ready_.empty()) {
      SensorEvent event = std::move(ready_.front());
      ready_.pop_front();
      validator_.check(std::move(event), passed_);
      continue;
    }
    if (finished_) {
      validator_.finish();
      if (!error_.empty()) throw InputError(error_);
      return false;
    }
    pcap::UdpDatagram d;
    if (reader_->next(d)) {
      ++datagrams_;
      stream_->handle(d.payload.data(), d.payload.size(), d.src_ip, d.dst_port, ready_);
      continue;
    }
    finished_ = true;
    stream_->finish(ready_);
    for (const auto& [why, n] : reader_->skipped()) validator_.count(why, "pcap records skipped", n);
    if (stream_->scans() > 0) continue;
    // No full frame: say why, once the events before it are delivered.
    std::string why;
    if (reader_->records() == 0) {
      why = "the capture holds no packets";
    } else if (stream_->datagrams_on_ports() == 0) {
      why = std::to_string(datagrams_) + " UDP datagrams, none on the metadata's lidar port " +
            std::to_string(meta_.udp_port_lidar) + " or IMU port " + std::to_string(meta_.udp_port_imu);
    } else if (stream_->lidar_packets() == 0 && !stream_->first_lidar_rejection().empty()) {
      why = "no lidar packet fits the metadata (wrong metadata for this capture?): " +
            stream_->first_lidar_rejection();
    } else if (stream_->lidar_packets() == 0) {
      why = "no lidar packets (" + std::to_string(stream_->imu_packets()) + " IMU packets)";
    } else {
      why = "no full frame in " + std::to_string(stream_->lidar_packets()) + " lidar packets (" +
            std::to_string(stream_->dropped_frames()) + " incomplete; " + stream_->last_dropped_frame() + ", " +
            std::to_string(meta_.window_columns()) + " columns make a full frame)";
    }
    error_ = "Ouster capture " + config_.pcap + " with metadata " + config_.metadata + ": " + why;
  }
}

}  // namespace fuse::io

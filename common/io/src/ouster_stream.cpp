#include "fuse/io/ouster_stream.hpp"

#include <algorithm>

#include "fuse/core/logging.hpp"

namespace fuse::io::ouster {

namespace {
constexpr const char* kOtherPort = "ouster_other_port";

bool later(const SensorEvent& a, const SensorEvent& b) { return a.arrival_time() > b.arrival_time(); }

std::string ip_text(std::uint32_t ip) {
  return std::to_string(ip >> 24) + "." + std::to_string((ip >> 16) & 0xFF) + "." + std::to_string((ip >> 8) & 0xFF) +
         "." + std::to_string(ip & 0xFF);
}
}  // namespace

Stream::Stream(Metadata meta, SourceValidator& validator, double reorder_window_s)
    : meta_(std::move(meta)), validator_(validator), reorder_window_s_(reorder_window_s), assembler_(meta_) {}

void Stream::learn(const std::uint8_t* data, std::size_t size, std::uint32_t src_ip, std::uint16_t dst_port) {
  const bool shared = meta_.udp_port_lidar == meta_.udp_port_imu;
  if (dst_port != meta_.udp_port_lidar || (shared && size == kImuPacketSize)) return;
  Rejection why;
  if (decode_lidar(data, size, meta_, packet_, why)) {
    ours_.insert(src_ip);
  } else if (!ours_.count(src_ip)) {
    others_.insert(src_ip);
  }
}

void Stream::handle(const std::uint8_t* data, std::size_t size, std::uint32_t src_ip, std::uint16_t dst_port,
                    std::deque<SensorEvent>& out) {
  const bool lidar_port = dst_port == meta_.udp_port_lidar && meta_.udp_port_lidar != 0;
  const bool imu_port = dst_port == meta_.udp_port_imu && meta_.udp_port_imu != 0;
  if (!lidar_port && !imu_port) {
    validator_.count(kOtherPort, "datagram to port " + std::to_string(dst_port) + " (lidar " +
                                     std::to_string(meta_.udp_port_lidar) + ", IMU " +
                                     std::to_string(meta_.udp_port_imu) + "): ignored");
    return;
  }
  ++on_ports_;
  Rejection why;
  if (imu_port && (!lidar_port || size == kImuPacketSize)) {
    const bool ours = ours_.count(src_ip) > 0 || (others_.empty() && !others_.count(src_ip));
    if (!ours) {
      validator_.count(reject::kOtherSensorImu,
                       "IMU packet from " + ip_text(src_ip) + ", which sends another sensor's lidar packets: ignored");
      return;
    }
    SensorEvent ev;
    ev.kind = SensorEvent::Kind::kImu;
    if (!decode_imu(data, size, ev.imu, why)) {
      validator_.count(why.reason, why.detail);
      return;
    }
    ++imu_packets_;
    ev.imu.sequence = imu_sequence_++;
    hold(std::move(ev));
  } else {
    if (!decode_lidar(data, size, meta_, packet_, why)) {
      if (!ours_.count(src_ip)) others_.insert(src_ip);
      if (first_lidar_rejection_.empty()) first_lidar_rejection_ = why.detail;
      validator_.count(why.reason, why.detail + " (from " + ip_text(src_ip) + ")");
      return;
    }
    ours_.insert(src_ip);
    ++lidar_packets_;
    std::vector<LidarScan> scans;
    std::vector<ScanAssembler::Dropped> dropped;
    assembler_.add(packet_, scans, dropped);
    report(dropped);
    for (auto& s : scans) {
      SensorEvent ev;
      ev.kind = SensorEvent::Kind::kLidar;
      ev.scan = std::move(s);
      ++scans_;
      hold(std::move(ev));
    }
    if (assembler_.empty_returns() > empty_reported_) {
      // Not a fault: pixels without an echo. Counted so points + empties = columns x beams.
      validator_.count(reject::kEmptyReturns, "pixels of range 0 (no return): no point",
                       assembler_.empty_returns() - empty_reported_);
      empty_reported_ = assembler_.empty_returns();
    }
  }
  release(newest_ - reorder_window_s_, out);
}

void Stream::report(const std::vector<ScanAssembler::Dropped>& dropped) {
  for (const auto& d : dropped) {
    ++dropped_frames_;
    last_dropped_ = "frame " + std::to_string(d.frame_id) + " has " + std::to_string(d.columns) + " of " +
                    std::to_string(d.expected) + " columns";
    validator_.count(reject::kIncompleteFrame, last_dropped_ + ": dropped (not a full frame)");
  }
}

void Stream::hold(SensorEvent&& ev) {
  const double t = ev.arrival_time();
  if (t < released_) {
    validator_.count(reject::kEventOrder, "event at t=" + std::to_string(t) + " arrived after events up to t=" +
                                              std::to_string(released_) + " were released: dropped");
    return;
  }
  newest_ = std::max(newest_, t);
  held_.push_back(std::move(ev));
  std::push_heap(held_.begin(), held_.end(), later);
}

void Stream::release(double horizon, std::deque<SensorEvent>& out) {
  while (!held_.empty() && held_.front().arrival_time() <= horizon) {
    std::pop_heap(held_.begin(), held_.end(), later);
    released_ = held_.back().arrival_time();
    out.push_back(std::move(held_.back()));
    held_.pop_back();
  }
}

void Stream::finish(std::deque<SensorEvent>& out) {
  std::vector<ScanAssembler::Dropped> dropped;
  assembler_.flush(dropped);
  report(dropped);
  release(1e300, out);
}

}  // namespace fuse::io::ouster

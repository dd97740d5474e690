// libFuzzer target for the Ouster packet decoders, the scan assembler and the per-sensor stream
// (issue 5: fuzz the packet decoders). The first input byte picks one of the small test layouts
// below (every lidar profile, windows that wrap, shared or separate ports), the rest is one UDP
// payload. Any byte string must be refused with a reason or decoded into finite points of
// non-negative time within their scan; never a crash or an out-of-bounds read (ASan/UBSan).
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <deque>
#include <memory>
#include <vector>

#include "fuse/io/ouster_metadata.hpp"
#include "fuse/io/ouster_packet.hpp"
#include "fuse/io/ouster_stream.hpp"
#include "fuse/io/source_validator.hpp"

namespace {

using namespace fuse::io;

void require(bool ok) {
  if (!ok) std::abort();  // an invariant broke: libFuzzer reports the input
}

/// Layouts small enough for the fuzzer to reach their exact packet sizes: 8 beams, 2 columns
/// per packet, 16 columns per frame (lidar_mode is only read by the parser, so set directly).
ouster::Metadata layout(int i) {
  ouster::Metadata m;
  m.name = "fuzz";
  m.lidar_profile = static_cast<ouster::LidarProfile>(i % 4);
  m.columns_per_frame = 16;
  m.frequency_hz = 10;
  m.columns_per_packet = 2;
  m.pixels_per_column = 8;
  for (int b = 0; b < 8; ++b) {
    m.beam_altitude_deg.push_back(20.0 - 5.0 * b);
    m.beam_azimuth_deg.push_back(b % 2 ? 1.5 : -1.5);
  }
  m.lidar_origin_to_beam_origin_mm = 15.8;
  m.beam_offset_x_mm = 15.8;
  m.lidar_to_sensor(2, 3) = 36.18;
  m.column_window_first = (i / 4) % 2 ? 12 : 0;  // a window that wraps past column 0, or all
  m.column_window_last = (i / 4) % 2 ? 3 : 15;
  m.udp_port_lidar = 7502;
  m.udp_port_imu = (i / 8) % 2 ? 7502 : 7503;  // shared or separate ports
  m.init_id = (i / 16) % 2 ? 0x123456 : 0;     // check the header's id, or not
  m.serial = (i / 16) % 2 ? 0x0102030405ull : 0;
  return m;
}

constexpr int kLayouts = 32;

struct Harness {
  SourceValidator validator{"fuzz"};
  std::vector<std::unique_ptr<ouster::Stream>> streams;
  Harness() {
    for (int i = 0; i < kLayouts; ++i) streams.push_back(std::make_unique<ouster::Stream>(layout(i), validator, 0.0));
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Harness h;
  if (size < 2) return 0;
  const int which = data[0] % kLayouts;
  const bool to_imu_port = (data[0] & 0x80) != 0;
  data += 1;
  size -= 1;
  const ouster::Metadata& meta = h.streams[static_cast<std::size_t>(which)]->metadata();

  ouster::LidarPacket packet;
  ouster::Rejection why;
  if (ouster::decode_lidar(data, size, meta, packet, why)) {
    require(size == meta.lidar_packet_size());
    require(packet.columns.size() == 2 && packet.pixels.size() == 16);
    for (const auto& c : packet.columns) require(!c.valid || c.measurement_id < meta.columns_per_frame);
  } else {
    require(why.reason != nullptr && !why.detail.empty());
  }
  fuse::ImuSample imu;
  if (ouster::decode_imu(data, size, imu, why)) {
    require(imu.accel.allFinite() && imu.gyro.allFinite() && std::isfinite(imu.t));
  }

  std::deque<SensorEvent> out;
  auto& stream = *h.streams[static_cast<std::size_t>(which)];
  stream.handle(data, size, 0x0A000001, to_imu_port ? meta.udp_port_imu : meta.udp_port_lidar, out);
  for (const auto& ev : out) {
    if (ev.kind != SensorEvent::Kind::kLidar) continue;
    require(ev.scan.t_end >= ev.scan.t_start);
    for (const auto& p : ev.scan.points) {
      require(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
      require(p.t_rel >= 0.0f && p.t_rel <= static_cast<float>(ev.scan.t_end - ev.scan.t_start) + 1e-3f);
      require(p.ring < 8);
    }
  }
  return 0;
}

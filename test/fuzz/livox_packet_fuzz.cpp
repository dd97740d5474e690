// libFuzzer target for the Livox SDK2 packet decoder and the scan assembler (issue 5: fuzz the
// packet decoders). Any byte string must be refused with a reason or decoded into exactly
// dot_num finite points (IMU: finite values) with non-decreasing times; never a crash or an
// out-of-bounds read (run under ASan/UBSan by the libFuzzer build).
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "fuse/io/livox_packet.hpp"
#include "fuse/io/livox_scan_assembler.hpp"

namespace {
/// Scan period the assembler is exercised with (the Mid-360 default).
constexpr double kScanPeriodS = 0.1;

void require(bool ok) {
  if (!ok) std::abort();  // an invariant broke: libFuzzer reports the input
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace fuse::io::livox;
  static ScanAssembler assembler(kScanPeriodS);
  Packet packet;
  DecodeError error;
  if (!decode_packet(data, size, packet, error)) {
    require(!error.reason.empty() && !error.message.empty());
    return 0;
  }
  require(packet.header.length == size);
  if (packet.header.data_type == static_cast<std::uint8_t>(DataType::kImu)) {
    require(packet.points.empty());
    require(packet.imu.gyro.allFinite() && packet.imu.accel.allFinite() && std::isfinite(packet.imu.t));
    return 0;
  }
  require(packet.points.size() == packet.header.dot_num);
  for (std::size_t i = 0; i < packet.points.size(); ++i) {
    const Point& p = packet.points[i];
    require(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) && std::isfinite(p.t));
    if (i > 0) require(p.t >= packet.points[i - 1].t);
  }
  std::vector<fuse::LidarScan> done;
  assembler.add(packet.points, done);
  for (const auto& scan : done) {
    require(scan.t_end > scan.t_start && !scan.points.empty());
    for (const auto& q : scan.points) require(q.t_rel >= 0.0f);
  }
  return 0;
}

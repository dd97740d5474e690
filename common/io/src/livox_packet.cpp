// Livox SDK2 packet decoding (see livox_packet.hpp for the layout and its source). The header's
// crc32 is not verified: the protocol's CRC variant could not be checked against a real capture
// here, and a wrong guess would refuse every packet of a real sensor. The length field, the
// version, the data type and dot_num against the payload size are checked instead.
#include "fuse/io/livox_packet.hpp"

#include <cmath>
#include <cstring>

namespace fuse::io::livox {
namespace {

constexpr std::size_t kImuRecordSize = 24;       // 6 x float32
constexpr std::size_t kCartesianHighSize = 14;   // 3 x int32 + 2 x uint8
constexpr std::size_t kCartesianLowSize = 8;     // 3 x int16 + 2 x uint8
constexpr std::size_t kSphericalSize = 10;       // uint32 + 2 x uint16 + 2 x uint8
constexpr double kMmToM = 1e-3;
constexpr double kCmToM = 1e-2;
constexpr double kCentiDegToRad = M_PI / 180.0 / 100.0;
constexpr double kNsToS = 1e-9;

// Header field offsets (protocol table).
constexpr std::size_t kOffVersion = 0, kOffLength = 1, kOffTimeInterval = 3, kOffDotNum = 5, kOffUdpCnt = 7,
                      kOffFrameCnt = 9, kOffDataType = 10, kOffTimeType = 11, kOffPackInfo = 12, kOffCrc = 24,
                      kOffTimestamp = 28;

template <class T>
T le(const std::uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));  // the host is little-endian, as the protocol
  return v;
}

template <class T>
void put(std::vector<std::uint8_t>& out, std::size_t offset, T v) {
  std::memcpy(out.data() + offset, &v, sizeof(T));
}

bool fail(DecodeError& e, const char* reason, std::string message) {
  e.reason = reason;
  e.message = std::move(message);
  return false;
}

}  // namespace

std::size_t point_size(std::uint8_t data_type) {
  switch (static_cast<DataType>(data_type)) {
    case DataType::kImu: return kImuRecordSize;
    case DataType::kCartesianHigh: return kCartesianHighSize;
    case DataType::kCartesianLow: return kCartesianLowSize;
    case DataType::kSpherical: return kSphericalSize;
  }
  return 0;
}

bool decode_packet(const std::uint8_t* data, std::size_t size, Packet& out, DecodeError& error) {
  if (size < kHeaderSize) {
    return fail(error, reject::kShort, "packet of " + std::to_string(size) + " bytes is shorter than the " +
                                           std::to_string(kHeaderSize) + "-byte header");
  }
  PacketHeader& h = out.header;
  h.version = data[kOffVersion];
  h.length = le<std::uint16_t>(data + kOffLength);
  h.time_interval = le<std::uint16_t>(data + kOffTimeInterval);
  h.dot_num = le<std::uint16_t>(data + kOffDotNum);
  h.udp_cnt = le<std::uint16_t>(data + kOffUdpCnt);
  h.frame_cnt = data[kOffFrameCnt];
  h.data_type = data[kOffDataType];
  h.time_type = data[kOffTimeType];
  h.pack_info = data[kOffPackInfo];
  h.crc32 = le<std::uint32_t>(data + kOffCrc);
  h.timestamp_ns = le<std::uint64_t>(data + kOffTimestamp);
  if (h.version != kProtocolVersion) {
    return fail(error, reject::kBadVersion, "protocol version " + std::to_string(h.version) + ", expected " +
                                                std::to_string(kProtocolVersion));
  }
  if (h.length != size) {
    return fail(error, reject::kLengthMismatch, "length field says " + std::to_string(h.length) +
                                                    " bytes, the datagram has " + std::to_string(size));
  }
  const std::size_t each = point_size(h.data_type);
  if (each == 0) return fail(error, reject::kUnknownDataType, "unknown data_type " + std::to_string(h.data_type));
  const std::size_t payload = size - kHeaderSize;
  const bool imu = h.data_type == static_cast<std::uint8_t>(DataType::kImu);
  if ((imu && (h.dot_num != 1 || payload != kImuRecordSize)) ||
      (!imu && static_cast<std::size_t>(h.dot_num) * each != payload)) {
    return fail(error, reject::kDotNumMismatch, "dot_num " + std::to_string(h.dot_num) + " of data_type " +
                                                    std::to_string(h.data_type) + " does not fill the " +
                                                    std::to_string(payload) + "-byte payload");
  }
  const std::uint8_t* p = data + kHeaderSize;
  const double t0 = static_cast<double>(h.timestamp_ns / 1'000'000'000ull) +
                    static_cast<double>(h.timestamp_ns % 1'000'000'000ull) * kNsToS;
  out.points.clear();
  if (imu) {
    float v[6];
    std::memcpy(v, p, sizeof(v));
    for (float f : v) {
      if (!std::isfinite(f)) return fail(error, reject::kNonFiniteImu, "IMU record holds a non-finite value");
    }
    out.imu.t = t0;
    out.imu.gyro = Eigen::Vector3d(v[0], v[1], v[2]);
    out.imu.accel = Eigen::Vector3d(v[3], v[4], v[5]) * kStandardGravity;
    return true;
  }
  const double step = h.dot_num > 0 ? h.time_interval * kTimeIntervalUnitS / h.dot_num : 0.0;
  out.points.resize(h.dot_num);
  for (std::size_t i = 0; i < h.dot_num; ++i, p += each) {
    Point& q = out.points[i];
    q.t = t0 + static_cast<double>(i) * step;
    switch (static_cast<DataType>(h.data_type)) {
      case DataType::kCartesianHigh:
        q.x = static_cast<float>(le<std::int32_t>(p) * kMmToM);
        q.y = static_cast<float>(le<std::int32_t>(p + 4) * kMmToM);
        q.z = static_cast<float>(le<std::int32_t>(p + 8) * kMmToM);
        q.reflectivity = p[12];
        q.tag = p[13];
        break;
      case DataType::kCartesianLow:
        q.x = static_cast<float>(le<std::int16_t>(p) * kCmToM);
        q.y = static_cast<float>(le<std::int16_t>(p + 2) * kCmToM);
        q.z = static_cast<float>(le<std::int16_t>(p + 4) * kCmToM);
        q.reflectivity = p[6];
        q.tag = p[7];
        break;
      default: {  // spherical: theta from +z (zenith), phi azimuth from +x
        const double r = le<std::uint32_t>(p) * kMmToM;
        const double theta = le<std::uint16_t>(p + 4) * kCentiDegToRad;
        const double phi = le<std::uint16_t>(p + 6) * kCentiDegToRad;
        q.x = static_cast<float>(r * std::sin(theta) * std::cos(phi));
        q.y = static_cast<float>(r * std::sin(theta) * std::sin(phi));
        q.z = static_cast<float>(r * std::cos(theta));
        q.reflectivity = p[8];
        q.tag = p[9];
        break;
      }
    }
  }
  return true;
}

std::vector<std::uint8_t> encode_packet(const PacketHeader& h, const std::vector<std::uint8_t>& payload) {
  std::vector<std::uint8_t> out(kHeaderSize + payload.size(), 0);
  out[kOffVersion] = h.version;
  put<std::uint16_t>(out, kOffLength, static_cast<std::uint16_t>(out.size()));
  put<std::uint16_t>(out, kOffTimeInterval, h.time_interval);
  put<std::uint16_t>(out, kOffDotNum, h.dot_num);
  put<std::uint16_t>(out, kOffUdpCnt, h.udp_cnt);
  out[kOffFrameCnt] = h.frame_cnt;
  out[kOffDataType] = h.data_type;
  out[kOffTimeType] = h.time_type;
  out[kOffPackInfo] = h.pack_info;
  put<std::uint32_t>(out, kOffCrc, h.crc32);
  put<std::uint64_t>(out, kOffTimestamp, h.timestamp_ns);
  if (!payload.empty()) std::memcpy(out.data() + kHeaderSize, payload.data(), payload.size());
  return out;
}

}  // namespace fuse::io::livox

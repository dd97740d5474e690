// The direct scan codec writes exactly the bytes Fast CDR writes for the generated
// fuse_msgs::LidarScan, and reads them (and Fast CDR's big-endian bytes) back unchanged.
#include <gtest/gtest.h>

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>

#include <random>

#include "fuse/io/cdr_codec.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse_msgs.h"

namespace fuse::io {
namespace {

namespace cdr = eprosima::fastcdr;

LidarScan random_scan(std::mt19937& rng, std::size_t n) {
  std::uniform_real_distribution<float> u(-50.f, 50.f);
  LidarScan s;
  s.t_start = 1700000000.123456789;
  s.t_end = s.t_start + 0.1;
  s.sequence = rng();
  for (std::size_t i = 0; i < n; ++i) {
    s.points.push_back(LidarPoint{u(rng), u(rng), u(rng), u(rng), u(rng) * 1e-3f, static_cast<std::uint16_t>(rng())});
  }
  return s;
}

std::vector<std::uint8_t> fast_cdr_bytes(const LidarScan& s, const std::string& frame, cdr::Cdr::Endianness endian) {
  fuse_msgs::LidarScan m;
  m.start_time(s.t_start);
  m.end_time(s.t_end);
  m.sequence_number(s.sequence);
  m.frame(frame.c_str());
  for (const LidarPoint& p : s.points) {
    fuse_msgs::LidarPoint q;
    q.x(p.x);
    q.y(p.y);
    q.z(p.z);
    q.intensity(p.intensity);
    q.time_offset(p.t_rel);
    q.ring(p.ring);
    m.points().push_back(q);
  }
  std::vector<std::uint8_t> out(fuse_msgs::LidarScan::getCdrSerializedSize(m) + 4, 0);
  cdr::FastBuffer buffer(reinterpret_cast<char*>(out.data()), out.size());
  cdr::Cdr ser(buffer, endian, cdr::Cdr::DDS_CDR);
  ser.serialize_encapsulation();
  m.serialize(ser);
  out.resize(ser.getSerializedDataLength());
  return out;
}

void expect_same(const LidarScan& a, const LidarScan& b) {
  EXPECT_EQ(a.t_start, b.t_start);
  EXPECT_EQ(a.t_end, b.t_end);
  EXPECT_EQ(a.sequence, b.sequence);
  ASSERT_EQ(a.points.size(), b.points.size());
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    EXPECT_EQ(a.points[i].x, b.points[i].x);
    EXPECT_EQ(a.points[i].y, b.points[i].y);
    EXPECT_EQ(a.points[i].z, b.points[i].z);
    EXPECT_EQ(a.points[i].intensity, b.points[i].intensity);
    EXPECT_EQ(a.points[i].t_rel, b.points[i].t_rel);
    EXPECT_EQ(a.points[i].ring, b.points[i].ring);
  }
}

class ScanCodec : public ::testing::TestWithParam<std::tuple<std::size_t, std::string>> {};

TEST_P(ScanCodec, SameBytesAsFastCdrAndBack) {
  const auto& [n, frame] = GetParam();
  std::mt19937 rng(static_cast<unsigned>(n * 31 + frame.size()));
  const LidarScan scan = random_scan(rng, n);
  const auto bytes = encode_scan(scan, frame);
  EXPECT_EQ(bytes, fast_cdr_bytes(scan, frame, cdr::Cdr::LITTLE_ENDIANNESS));
  std::string got_frame;
  expect_same(decode_scan(kLidarScanSchemaName, bytes.data(), bytes.size(), &got_frame), scan);
  EXPECT_EQ(got_frame, frame);
  // Big-endian samples (another writer's choice) decode to the same scan.
  const auto big = fast_cdr_bytes(scan, frame, cdr::Cdr::BIG_ENDIANNESS);
  ASSERT_EQ(big[1], 0x00);
  got_frame.clear();
  expect_same(decode_scan(kLidarScanSchemaName, big.data(), big.size(), &got_frame), scan);
  EXPECT_EQ(got_frame, frame);
}

// Frame lengths 0..4 walk the count's alignment through every remainder.
INSTANTIATE_TEST_SUITE_P(PointCountsAndFrames, ScanCodec,
                         ::testing::Combine(::testing::Values(std::size_t{0}, std::size_t{1}, std::size_t{2},
                                                              std::size_t{20000}),
                                            ::testing::Values(std::string(""), std::string("l"), std::string("li"),
                                                              std::string("lid"), std::string("lidar"),
                                                              std::string(64, 'f'))));

TEST(ScanCodecLimits, RefusesAFrameNameOverTheBound) {
  LidarScan scan;
  EXPECT_THROW(encode_scan(scan, std::string(65, 'f')), std::invalid_argument);
}

}  // namespace
}  // namespace fuse::io

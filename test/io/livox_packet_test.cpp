// Livox SDK2 packet decoding and scan assembly, on packets built from the protocol document
// (livox_test_packets.hpp): every data type with known points and IMU values, per-point times,
// and malformed packets refused with their reason.
#include <gtest/gtest.h>

#include "fuse/io/livox_packet.hpp"
#include "fuse/io/livox_scan_assembler.hpp"
#include "livox_test_packets.hpp"

namespace fuse::io::livox {
namespace {

namespace tp = fuse::test::livox;

constexpr std::uint64_t kT0Ns = 1'700'000'000'123'456'789ull;
constexpr double kT0 = 1'700'000'000.123456789;

std::vector<tp::RawPoint> sample_points() {
  return {{1.0, -2.0, 0.5, 10, 0}, {12.34, 0.56, -1.2, 200, 1}, {-3.0, 4.0, 2.5, 255, 2}};
}

Packet decode_ok(const std::vector<std::uint8_t>& bytes) {
  Packet p;
  DecodeError e;
  EXPECT_TRUE(decode_packet(bytes.data(), bytes.size(), p, e)) << e.reason << ": " << e.message;
  return p;
}

void expect_times(const Packet& p, std::uint16_t time_interval) {
  for (std::size_t i = 0; i < p.points.size(); ++i) {
    const double expected = kT0 + static_cast<double>(i) * time_interval * 1e-7 / static_cast<double>(p.points.size());
    EXPECT_NEAR(p.points[i].t, expected, 1e-6) << "point " << i;
  }
}

TEST(LivoxPacket, CartesianMillimetres) {
  const auto pts = sample_points();
  const auto p = decode_ok(tp::packet(1, 3, 1000, kT0Ns, tp::point_data(1, pts)));
  ASSERT_EQ(p.points.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_FLOAT_EQ(p.points[i].x, static_cast<float>(pts[i].x));
    EXPECT_FLOAT_EQ(p.points[i].y, static_cast<float>(pts[i].y));
    EXPECT_FLOAT_EQ(p.points[i].z, static_cast<float>(pts[i].z));
    EXPECT_EQ(p.points[i].reflectivity, pts[i].reflectivity);
    EXPECT_EQ(p.points[i].tag, pts[i].tag);
  }
  EXPECT_EQ(p.header.udp_cnt, 7);
  EXPECT_EQ(p.header.frame_cnt, 3);
  EXPECT_EQ(p.header.timestamp_ns, kT0Ns);
  expect_times(p, 1000);  // 100 us over 3 points: 33.3 us apart
}

TEST(LivoxPacket, CartesianCentimetres) {
  const auto pts = sample_points();
  const auto p = decode_ok(tp::packet(2, 3, 500, kT0Ns, tp::point_data(2, pts)));
  ASSERT_EQ(p.points.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_NEAR(p.points[i].x, pts[i].x, 1e-6);  // the values are whole centimetres
    EXPECT_NEAR(p.points[i].y, pts[i].y, 1e-6);
    EXPECT_NEAR(p.points[i].z, pts[i].z, 1e-6);
    EXPECT_EQ(p.points[i].reflectivity, pts[i].reflectivity);
  }
  expect_times(p, 500);
}

TEST(LivoxPacket, SphericalDepthThetaPhi) {
  // Axis-aligned points are exact; the others are within the 1 mm / 0.01 degree quantisation.
  const std::vector<tp::RawPoint> pts = {{10, 0, 0}, {0, 10, 0}, {0, 0, 10}, {0, -5, 0}, {-3, 4, 2.5}};
  const auto p = decode_ok(tp::packet(3, 5, 2000, kT0Ns, tp::point_data(3, pts)));
  ASSERT_EQ(p.points.size(), pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const double r = std::sqrt(pts[i].x * pts[i].x + pts[i].y * pts[i].y + pts[i].z * pts[i].z);
    const double tol = 1e-3 + r * 0.01 * M_PI / 180.0;
    EXPECT_NEAR(p.points[i].x, pts[i].x, tol) << i;
    EXPECT_NEAR(p.points[i].y, pts[i].y, tol) << i;
    EXPECT_NEAR(p.points[i].z, pts[i].z, tol) << i;
  }
  expect_times(p, 2000);
}

TEST(LivoxPacket, ImuInRadiansPerSecondAndG) {
  const auto p = decode_ok(tp::packet(0, 1, 0, kT0Ns, tp::imu_data(0.1f, -0.2f, 0.3f, 0.0f, 0.5f, 1.0f)));
  EXPECT_TRUE(p.points.empty());
  EXPECT_NEAR(p.imu.t, kT0, 1e-6);
  EXPECT_DOUBLE_EQ(p.imu.gyro.x(), static_cast<double>(0.1f));
  EXPECT_DOUBLE_EQ(p.imu.gyro.y(), static_cast<double>(-0.2f));
  EXPECT_DOUBLE_EQ(p.imu.gyro.z(), static_cast<double>(0.3f));
  EXPECT_DOUBLE_EQ(p.imu.accel.x(), 0.0);
  EXPECT_DOUBLE_EQ(p.imu.accel.y(), 0.5 * 9.80665);
  EXPECT_DOUBLE_EQ(p.imu.accel.z(), 9.80665);
}

TEST(LivoxPacket, MalformedPacketsAreRefusedWithTheirReason) {
  const auto good = tp::packet(1, 3, 1000, kT0Ns, tp::point_data(1, sample_points()));
  struct Case {
    std::vector<std::uint8_t> bytes;
    const char* reason;
  };
  auto truncated = good;
  truncated.resize(good.size() - 5);  // the length field still says the full size
  const std::vector<Case> cases = {
      {std::vector<std::uint8_t>(good.begin(), good.begin() + 20), reject::kShort},
      {{}, reject::kShort},
      {truncated, reject::kLengthMismatch},
      {tp::packet(1, 3, 1000, kT0Ns, tp::point_data(1, sample_points()), 0, 999), reject::kLengthMismatch},
      {tp::packet(1, 3, 1000, kT0Ns, tp::point_data(1, sample_points()), 5), reject::kBadVersion},
      {tp::packet(7, 3, 1000, kT0Ns, tp::point_data(1, sample_points())), reject::kUnknownDataType},
      {tp::packet(0x11, 3, 1000, kT0Ns, tp::point_data(1, sample_points())), reject::kUnknownDataType},
      {tp::packet(1, 4, 1000, kT0Ns, tp::point_data(1, sample_points())), reject::kDotNumMismatch},
      {tp::packet(2, 3, 1000, kT0Ns, tp::point_data(1, sample_points())), reject::kDotNumMismatch},
      {tp::packet(0, 2, 0, kT0Ns, tp::imu_data(0, 0, 0, 0, 0, 1)), reject::kDotNumMismatch},
      {tp::packet(0, 1, 0, kT0Ns, tp::imu_data(0, NAN, 0, 0, 0, 1)), reject::kNonFiniteImu},
  };
  for (std::size_t i = 0; i < cases.size(); ++i) {
    Packet p;
    DecodeError e;
    EXPECT_FALSE(decode_packet(cases[i].bytes.data(), cases[i].bytes.size(), p, e)) << "case " << i;
    EXPECT_EQ(e.reason, cases[i].reason) << "case " << i << ": " << e.message;
    EXPECT_FALSE(e.message.empty());
  }
}

TEST(LivoxPacket, EncoderWritesTheDocumentedLayout) {
  PacketHeader h;
  h.time_interval = 1000;
  h.dot_num = 3;
  h.udp_cnt = 7;
  h.frame_cnt = 3;
  h.data_type = 1;
  h.timestamp_ns = kT0Ns;
  const auto data = tp::point_data(1, sample_points());
  EXPECT_EQ(encode_packet(h, data), tp::packet(1, 3, 1000, kT0Ns, data));
}

TEST(LivoxScanAssembler, ScansOfTheConfiguredPeriodByPointTime) {
  ScanAssembler assembler(0.1);
  std::vector<LidarScan> done;
  // 0.35 s of points, 1 ms apart, in packets of 10: scans [0, 0.1), [0.1, 0.2), [0.2, 0.3) complete.
  constexpr int kPoints = 350;
  std::vector<Point> all;
  for (int i = 0; i < kPoints; ++i) {
    Point p;
    p.x = 1.0f + static_cast<float>(i);
    p.t = 100.0 + i * 1e-3;
    all.push_back(p);
  }
  for (int i = 0; i < kPoints; i += 10) assembler.add(std::vector<Point>(all.begin() + i, all.begin() + i + 10), done);
  ASSERT_EQ(done.size(), 3u);
  std::size_t seen = 0;
  for (std::size_t k = 0; k < done.size(); ++k) {
    EXPECT_NEAR(done[k].t_start, 100.0 + 0.1 * static_cast<double>(k), 1e-9);
    EXPECT_NEAR(done[k].t_end - done[k].t_start, 0.1, 1e-9);
    EXPECT_EQ(done[k].sequence, k);
    EXPECT_NEAR(static_cast<double>(done[k].points.size()), 100.0, 1.0);
    for (const auto& q : done[k].points) {
      EXPECT_GE(q.t_rel, 0.0f);
      EXPECT_LT(q.t_rel, 0.1f);
      // The point keeps its own time: t_start + t_rel is the time it was built with.
      EXPECT_NEAR(done[k].t_start + q.t_rel, 100.0 + (q.x - 1.0) * 1e-3, 1e-6);
    }
    seen += done[k].points.size();
  }
  const auto rest = assembler.flush();
  ASSERT_TRUE(rest.has_value());
  EXPECT_EQ(seen + rest->points.size(), static_cast<std::size_t>(kPoints));
}

TEST(LivoxScanAssembler, LatePointsAndEmptyReturnsAreCounted) {
  ScanAssembler assembler(0.1);
  std::vector<LidarScan> done;
  Point a, b, zero, late;
  a.x = b.x = late.x = 1.0f;
  a.t = 10.0;
  b.t = 10.25;  // completes [10.0, 10.1); the next scan is [10.2, 10.3)
  zero.t = 10.26;
  late.t = 10.15;
  assembler.add({a, b, zero, late}, done);
  EXPECT_EQ(done.size(), 1u);
  EXPECT_EQ(assembler.late_points(), 1u);
  EXPECT_EQ(assembler.empty_returns(), 1u);
  EXPECT_THROW(ScanAssembler(0.0), std::invalid_argument);
}

}  // namespace
}  // namespace fuse::io::livox

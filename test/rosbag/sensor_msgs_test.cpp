// Decoders of sensor_msgs/Imu, sensor_msgs/PointCloud2 (every per-point time convention) and
// Livox CustomMsg in ROS 1 serialisation and CDR, on messages with known contents; every
// truncation of a valid message, and inconsistent clouds, give InputError.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "fuse/io/sensor_source.hpp"
#include "fuse/rosbag/scan_conversion.hpp"
#include "fuse/rosbag/sensor_msgs.hpp"
#include "message_encoder.hpp"

namespace fuse::rosbag {
namespace {

constexpr std::uint64_t kStamp = 1700000000123456789ull;
const double kStampS = 1700000000.123456789;

std::vector<std::uint8_t> imu_bytes(Serialization s) {
  test::Encoder e(s);
  e.header(kStamp, "imu_link");
  for (double v : {0.0, 0.0, 0.0, 1.0}) e.put(v);
  for (int i = 0; i < 9; ++i) e.put(0.01 * i);
  for (double v : {0.1, -0.2, 0.3}) e.put(v);
  for (int i = 0; i < 9; ++i) e.put(0.0);
  for (double v : {0.5, 0.25, 9.75}) e.put(v);
  for (int i = 0; i < 9; ++i) e.put(0.0);
  return e.buf;
}

/// A 2 x 3 cloud with fields x y z intensity ring + the time field `time_field` (its datatype
/// per the driver convention); the middle point of row 1 is NaN, the last one at the origin.
std::vector<std::uint8_t> cloud_bytes(Serialization s, const std::string& time_field, bool big_endian = false) {
  struct F {
    std::string name;
    std::uint32_t offset;
    std::uint8_t type;
  };
  std::vector<F> fields = {{"x", 0, 7}, {"y", 4, 7}, {"z", 8, 7}, {"intensity", 12, 7}, {"ring", 16, 4}};
  std::uint8_t ttype = time_field == "time" ? 7 : time_field == "timestamp" ? 8 : 6;
  fields.push_back({time_field, 20, ttype});
  const std::uint32_t step = 28, width = 3, height = 2;
  std::vector<std::uint8_t> data(height * width * step, 0);
  auto put = [&](std::size_t at, const void* v, std::size_t n) {
    std::memcpy(data.data() + at, v, n);
    if (big_endian) std::reverse(data.begin() + static_cast<std::ptrdiff_t>(at), data.begin() + static_cast<std::ptrdiff_t>(at + n));
  };
  for (std::uint32_t i = 0; i < height * width; ++i) {
    const std::size_t b = i * step;
    float xyz[3] = {1.0f + static_cast<float>(i), 2.0f, -0.5f * static_cast<float>(i)};
    if (i == 4) xyz[0] = std::numeric_limits<float>::quiet_NaN();
    if (i == 5) xyz[0] = xyz[1] = xyz[2] = 0.f;
    for (int k = 0; k < 3; ++k) put(b + 4 * k, &xyz[k], 4);
    const float intensity = 10.f * static_cast<float>(i);
    put(b + 12, &intensity, 4);
    const std::uint16_t ring = static_cast<std::uint16_t>(i % 3);
    put(b + 16, &ring, 2);
    // Point i is taken 10 ms * i after the stamp (time: 5 ms before the stamp for point 0).
    if (time_field == "time") {
      const float t = 0.01f * static_cast<float>(i) - 0.005f;
      put(b + 20, &t, 4);
    } else if (time_field == "timestamp") {
      const double t = kStampS + 0.01 * i;
      put(b + 20, &t, 8);
    } else {
      const std::uint32_t t = 10000000u * i;
      put(b + 20, &t, 4);
    }
  }
  test::Encoder e(s);
  e.header(kStamp, "lidar");
  e.put<std::uint32_t>(height);
  e.put<std::uint32_t>(width);
  e.put<std::uint32_t>(static_cast<std::uint32_t>(fields.size()));
  for (const auto& f : fields) {
    e.str(f.name);
    e.put<std::uint32_t>(f.offset);
    e.put<std::uint8_t>(f.type);
    e.put<std::uint32_t>(1);
  }
  e.put<std::uint8_t>(big_endian ? 1 : 0);
  e.put<std::uint32_t>(step);
  e.put<std::uint32_t>(step * width);
  e.put<std::uint32_t>(static_cast<std::uint32_t>(data.size()));
  e.buf.insert(e.buf.end(), data.begin(), data.end());
  e.put<std::uint8_t>(0);
  return e.buf;
}

std::vector<std::uint8_t> livox_bytes(Serialization s, std::uint32_t n = 4) {
  test::Encoder e(s);
  e.header(kStamp, "livox_frame");
  e.put<std::uint64_t>(kStamp);
  e.put<std::uint32_t>(n);
  e.put<std::uint8_t>(3);
  for (int i = 0; i < 3; ++i) e.put<std::uint8_t>(0);
  e.put<std::uint32_t>(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    e.put<std::uint32_t>(1000u * i);
    e.put<float>(static_cast<float>(i) + 1.f);
    e.put<float>(-1.f);
    e.put<float>(0.5f);
    e.put<std::uint8_t>(static_cast<std::uint8_t>(100 + i));
    e.put<std::uint8_t>(0x10);
    e.put<std::uint8_t>(static_cast<std::uint8_t>(i % 4));
  }
  return e.buf;
}

class Wire : public ::testing::TestWithParam<Serialization> {};

TEST_P(Wire, Imu) {
  const auto b = imu_bytes(GetParam());
  const ImuMsg m = decode_imu(b.data(), b.size(), GetParam(), "test");
  EXPECT_EQ(m.stamp_ns, kStamp);
  EXPECT_EQ(m.frame_id, "imu_link");
  EXPECT_EQ(m.angular_velocity, Eigen::Vector3d(0.1, -0.2, 0.3));
  EXPECT_EQ(m.linear_acceleration, Eigen::Vector3d(0.5, 0.25, 9.75));
  const ImuSample s = imu_to_sample(m, 9.80665);
  EXPECT_NEAR(s.t, kStampS, 1e-6);
  EXPECT_DOUBLE_EQ(s.accel.z(), 9.75 * 9.80665);
}

TEST_P(Wire, Livox) {
  const auto b = livox_bytes(GetParam());
  const LivoxCustomMsg m = decode_livox_custom(b.data(), b.size(), GetParam(), "test");
  EXPECT_EQ(m.timebase, kStamp);
  EXPECT_EQ(m.lidar_id, 3);
  ASSERT_EQ(m.points.size(), 4u);
  EXPECT_EQ(m.points[3].offset_time, 3000u);
  EXPECT_EQ(m.points[3].reflectivity, 103);
  EXPECT_EQ(m.points[3].line, 3);
  PointCounts counts;
  const LidarScan scan = livox_to_scan(m, counts);
  EXPECT_NEAR(scan.t_start, kStampS, 1e-6);
  EXPECT_NEAR(scan.t_end - scan.t_start, 3e-6, 5e-7);  // absolute seconds: ~0.2 us resolution
  EXPECT_FLOAT_EQ(scan.points[2].x, 3.f);
  EXPECT_NEAR(scan.points[2].t_rel, 2e-6, 1e-9);
  EXPECT_EQ(scan.points[2].ring, 2);
}

TEST_P(Wire, EveryTruncationIsAnInputError) {
  const Serialization s = GetParam();
  auto check = [s](const std::vector<std::uint8_t>& b, auto decode) {
    for (std::size_t n = 0; n < b.size(); ++n) {
      const std::vector<std::uint8_t> cut(b.begin(), b.begin() + static_cast<std::ptrdiff_t>(n));
      EXPECT_THROW(decode(cut.data(), cut.size(), s, "cut"), io::InputError) << "cut at " << n << " of " << b.size();
    }
  };
  check(imu_bytes(s), decode_imu);
  check(cloud_bytes(s, "t"), decode_point_cloud2);
  check(livox_bytes(s), decode_livox_custom);
}

INSTANTIATE_TEST_SUITE_P(Ros1AndCdr, Wire, ::testing::Values(Serialization::kRos1, Serialization::kCdr),
                         [](const auto& info) { return info.param == Serialization::kRos1 ? "ros1" : "cdr"; });

struct CloudCase {
  std::string time_field;
  Serialization s;
  bool big_endian;
  double first_offset_s;  ///< first point's time relative to the stamp
};

class Cloud : public ::testing::TestWithParam<CloudCase> {};

TEST_P(Cloud, TimeFieldConvention) {
  const auto& c = GetParam();
  const auto b = cloud_bytes(c.s, c.time_field, c.big_endian);
  const PointCloud2Msg m = decode_point_cloud2(b.data(), b.size(), c.s, "test");
  EXPECT_EQ(m.height, 2u);
  EXPECT_EQ(m.width, 3u);
  EXPECT_EQ(m.is_bigendian, c.big_endian);
  PointCounts counts;
  const LidarScan scan = cloud_to_scan(m, "", counts, "test");
  EXPECT_EQ(counts.kept, 4u);
  EXPECT_EQ(counts.nan_points, 1u);
  EXPECT_EQ(counts.zero_points, 1u);
  ASSERT_EQ(scan.points.size(), 4u);
  EXPECT_NEAR(scan.t_start, kStampS + c.first_offset_s, 2e-6);
  EXPECT_NEAR(scan.t_end - scan.t_start, 0.03, 1e-6);  // points 0..3 kept: 30 ms apart
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_FLOAT_EQ(scan.points[i].x, 1.f + static_cast<float>(i));
    EXPECT_FLOAT_EQ(scan.points[i].z, -0.5f * static_cast<float>(i));
    EXPECT_FLOAT_EQ(scan.points[i].intensity, 10.f * static_cast<float>(i));
    EXPECT_EQ(scan.points[i].ring, i % 3);
    EXPECT_NEAR(scan.points[i].t_rel, 0.01 * static_cast<double>(i), 2e-6);
  }
  // The named field gives the same; another name is a clear error.
  EXPECT_EQ(cloud_to_scan(m, c.time_field, counts, "test").points.size(), 4u);
  const std::string other = c.time_field == "t" ? "offset_time" : "t";
  try {
    cloud_to_scan(m, other, counts, "test");
    ADD_FAILURE();
  } catch (const io::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no per-point time field '" + other + "'"), std::string::npos) << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(
    Conventions, Cloud,
    ::testing::Values(CloudCase{"t", Serialization::kRos1, false, 0.0}, CloudCase{"t", Serialization::kCdr, false, 0.0},
                      CloudCase{"time", Serialization::kRos1, false, -0.005},
                      CloudCase{"time", Serialization::kCdr, true, -0.005},
                      CloudCase{"timestamp", Serialization::kCdr, false, 0.0},
                      CloudCase{"timestamp", Serialization::kRos1, true, 0.0},
                      CloudCase{"offset_time", Serialization::kCdr, false, 0.0}),
    [](const auto& info) {
      return info.param.time_field + (info.param.s == Serialization::kRos1 ? "_ros1" : "_cdr") +
             (info.param.big_endian ? "_be" : "");
    });

TEST(Cloud, InconsistentCloudsAreRefused) {
  const auto b = cloud_bytes(Serialization::kRos1, "t");
  const PointCloud2Msg good = decode_point_cloud2(b.data(), b.size(), Serialization::kRos1, "test");
  PointCounts counts;
  auto expect_error = [&](PointCloud2Msg m, const std::string& what) {
    try {
      cloud_to_scan(m, "", counts, "cloud");
      ADD_FAILURE() << "no error for " << what;
    } catch (const io::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  PointCloud2Msg m = good;
  m.height = 3;
  expect_error(m, "data bytes");
  m = good;
  m.point_step = 20;
  expect_error(m, "outside point_step");
  m = good;
  m.row_step = 10;
  expect_error(m, "row_step");
  m = good;
  m.fields[0].datatype = 9;
  expect_error(m, "unknown datatype");
  m = good;
  m.fields.erase(m.fields.begin() + 1);
  expect_error(m, "no x, y, z");
  m = good;
  m.fields.pop_back();
  expect_error(m, "no per-point time field");
  m = good;
  m.fields.back().name = "time";  // uint32 ns read as seconds: 50 ms become 5e7 s
  expect_error(m, "not one scan (wrong --time-field or unit?)");
  EXPECT_THROW(cloud_to_scan(good, "ring", counts, "cloud"), io::InputError);  // not a time convention
}

TEST(Livox, PointNumMismatchAndWrongEncapsulation) {
  auto b = livox_bytes(Serialization::kRos1);
  b[4 + 4 + 4 + 4 + 11 + 8] = 9;  // point_num (after seq, stamp, frame_id "livox_frame", timebase)
  EXPECT_THROW(decode_livox_custom(b.data(), b.size(), Serialization::kRos1, "t"), io::InputError);
  auto c = imu_bytes(Serialization::kCdr);
  c[0] = 1;
  EXPECT_THROW(decode_imu(c.data(), c.size(), Serialization::kCdr, "t"), io::InputError);
  // A huge array count is refused before allocating.
  auto d = livox_bytes(Serialization::kCdr, 0);
  d[d.size() - 4] = 0xff;
  d[d.size() - 1] = 0x7f;
  EXPECT_THROW(decode_livox_custom(d.data(), d.size(), Serialization::kCdr, "t"), io::InputError);
}

}  // namespace
}  // namespace fuse::rosbag

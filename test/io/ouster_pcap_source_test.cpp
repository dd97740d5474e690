// Ouster replay on the real captures of ouster-sdk's test data (../shared/data/ouster): every
// capture with its metadata gives either scans and IMU samples, checked for what a full frame
// must be (columns x beams less the empty returns, point times spanning the frame, about 1 g at
// rest at 100 Hz), or a clear error naming why. Plus the metadata layouts, the projection of
// one pixel computed by hand, the extrinsic, and the same_ports captures split per sensor.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include "fuse/io/ouster_metadata.hpp"
#include "fuse/io/ouster_packet.hpp"
#include "fuse/io/ouster_pcap_source.hpp"
#include "test_util.hpp"

namespace fuse::io {
namespace {

std::string data(const std::string& f) { return test::shared_data("ouster/" + f); }

struct Capture {
  const char* pcap;
  const char* metadata;
  int scans;              ///< full frames expected; -1: an InputError is expected
  const char* error;      ///< substring of the error (when scans == -1)
  int imu;                ///< IMU samples expected (-1: do not check)
  double g_tolerance = 0.5;  ///< |mean |accel| - 9.81| allowed (m/s^2); wider for a moving sensor
};

std::string test_name(const Capture& c) {
  std::string n = std::string(c.pcap) + "__" + c.metadata;
  for (char& ch : n) {
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  }
  return n;
}

struct Replay {
  std::vector<LidarScan> scans;
  std::vector<ImuSample> imu;
  SourceStats stats;
  std::string error;
  std::unique_ptr<OusterPcapSource> source;
};

Replay replay(const std::string& pcap, const std::string& metadata) {
  Replay r;
  try {
    r.source = std::make_unique<OusterPcapSource>(OusterPcapConfig{pcap, metadata, {}, {}});
    SensorEvent ev;
    double last = -1e300;
    while (r.source->next(ev)) {
      EXPECT_GE(ev.arrival_time(), last) << "events in time order";
      last = ev.arrival_time();
      if (ev.kind == SensorEvent::Kind::kLidar) {
        r.scans.push_back(ev.scan);
      } else {
        r.imu.push_back(ev.imu);
      }
    }
  } catch (const InputError& e) {
    r.error = e.what();
  }
  if (r.source) r.stats = r.source->stats();
  return r;
}

class OusterCaptures : public ::testing::TestWithParam<Capture> {};

TEST_P(OusterCaptures, DecodeOrGiveAClearError) {
  const Capture& c = GetParam();
  FUSE_REQUIRE_SHARED(data(c.pcap));
  Replay r = replay(data(c.pcap), data(c.metadata));
  if (c.scans < 0) {
    ASSERT_FALSE(r.error.empty()) << "expected an error containing '" << c.error << "'";
    EXPECT_NE(r.error.find(c.error), std::string::npos) << r.error;
    return;
  }
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(static_cast<int>(r.scans.size()), c.scans);
  const ouster::Metadata meta = ouster::load_metadata(data(c.metadata));
  const std::size_t pixels = static_cast<std::size_t>(meta.window_columns()) * meta.pixels_per_column;
  const std::uint64_t empty = r.stats.rejected.count(ouster::reject::kEmptyReturns)
                                  ? r.stats.rejected.at(ouster::reject::kEmptyReturns)
                                  : 0;
  std::size_t points = 0;
  const double frame_s = 1.0 / meta.frequency_hz;
  // First to last column time: the lowest to the highest measurement id in the window (a window
  // that wraps past column 0 holds both ends of the revolution in one frame id).
  int m_lo = meta.columns_per_frame, m_hi = -1;
  for (int m = 0; m < meta.columns_per_frame; ++m) {
    if (meta.in_window(m)) {
      m_lo = std::min(m_lo, m);
      m_hi = std::max(m_hi, m);
    }
  }
  const double span_expected = frame_s * (m_hi - m_lo) / meta.columns_per_frame;
  for (const auto& s : r.scans) {
    points += s.points.size();
    EXPECT_GT(s.points.size(), pixels / 4) << "most pixels have a return";
    // The scan spans its window's columns: 0.1 s per revolution at 10 Hz (±2 %).
    EXPECT_NEAR(s.t_end - s.t_start, span_expected, 0.02 * frame_s);
    float lo = 1e9f, hi = -1e9f;
    for (const auto& p : s.points) {
      lo = std::min(lo, p.t_rel);
      hi = std::max(hi, p.t_rel);
      ASSERT_LT(p.ring, meta.pixels_per_column);
      const double range = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
      ASSERT_LT(range, 2100.0);
    }
    EXPECT_NEAR(lo, 0.0, 2e-3) << "the first columns have returns";
    EXPECT_NEAR(hi, s.t_end - s.t_start, 2e-3) << "point times span the frame";
  }
  EXPECT_EQ(points + empty, pixels * r.scans.size()) << "points + empty returns = columns x beams per frame";
  if (c.imu >= 0) {
    EXPECT_EQ(static_cast<int>(r.imu.size()), c.imu);
  }
  if (r.imu.size() >= 2) {
    double g = 0.0;
    for (const auto& s : r.imu) g += s.accel.norm();
    g /= static_cast<double>(r.imu.size());
    EXPECT_NEAR(g, 9.81, c.g_tolerance) << "about 1 g";
    const double rate = static_cast<double>(r.imu.size() - 1) / (r.imu.back().t - r.imu.front().t);
    EXPECT_NEAR(rate, 100.0, 5.0) << "IMU at 100 Hz";
    // IMU and lidar on one clock: the samples interleave with the scans.
    EXPECT_LT(std::abs(r.imu.front().t - r.scans.front().t_start), 0.2);
  }
  ASSERT_TRUE(r.source->T_imu_lidar().has_value());
}

INSTANTIATE_TEST_SUITE_P(
    Ouster, OusterCaptures,
    ::testing::Values(
        Capture{"OS-0-128-U1_v2.3.0_1024x10.pcap", "OS-0-128-U1_v2.3.0_1024x10.json", 1, "", 10},
        Capture{"OS-0-32-U1_v2.2.0_1024x10.pcap", "OS-0-32-U1_v2.2.0_1024x10.json", 1, "", 10},
        // The sensor moves in this capture (the README of the data says so): mean |a| 10.7 m/s^2.
        Capture{"OS-1-128_v2.3.0_1024x10_lb_n3.pcap", "OS-1-128_v2.3.0_1024x10.json", 3, "", 30, 1.5},
        Capture{"OS-1-32-G_v2.1.1_1024x10.pcap", "OS-1-32-G_v2.1.1_1024x10.json", 1, "", 0},
        Capture{"OS-2-128-U1_v2.3.0_1024x10.pcap", "OS-2-128-U1_v2.3.0_1024x10.json", 1, "", 10},
        Capture{"OS-2-32-U0_v2.0.0_1024x10.pcap", "OS-2-32-U0_v2.0.0_1024x10.json", 1, "", 0},
        Capture{"crc_test.pcap", "crc_test.json", 1, "", 10},
        Capture{"windowed_frame1.pcap", "windowed_frame1_0.json", 1, "", 10},
        Capture{"windowed_frame2.pcap", "windowed_frame2_0.json", 1, "", 10},
        Capture{"pcap_with_extrinsics/OS-0-128-U1_v2.3.0_10.pcap", "pcap_with_extrinsics/OS-0-128-U1_v2.3.0_1024x10.json",
                1, "", 10},
        // Clear errors.
        Capture{"empty_pcap.pcap", "empty_pcap.json", -1, "the capture holds no packets", 0},
        Capture{"OS-0-32-U1_v2.2.0_1024x10-single-packet.pcap", "OS-0-32-U1_v2.2.0_1024x10.json", -1,
                "no full frame in 1 lidar packets", 0},
        Capture{"duplicate_id.pcap", "duplicate_id.json", -1, "no full frame in 1 lidar packets", 0},
        Capture{"OS-1-128_767798045_1024x10_20230712_120049.pcap", "OS-1-128_767798045_1024x10_20230712_120049.json",
                -1, "'FUSA_RNG15_RFL8_NIR8_DUAL', a lidar packet profile not read here", 0},
        Capture{"imu_zm_no_lidar.pcap", "imu_zm_no_lidar_0.json", -1, "RNG19_RFL8_SIG16_NIR16_ZONE16", 0},
        Capture{"shot_limiting_test.pcap", "shot_limiting_test.json", -1,
                "'ACCEL32_GYRO32_NMEA', an IMU packet profile not read here", 0},
        Capture{"OS-1-64_1024x10_fw20.pcap", "OS-1-64_sensor_config_reduced.json", -1,
                "field 'beam_intrinsics.lidar_origin_to_beam_origin_mm or lidar_origin_to_beam_origin_mm' is missing", 0},
        // Wrong metadata for a capture: the packet size says so.
        Capture{"OS-2-128-U1_v2.3.0_1024x10.pcap", "OS-1-128_v2.3.0_1024x10.json", -1,
                "no lidar packet fits the metadata (wrong metadata for this capture?): lidar packet of 24832 bytes, "
                "metadata's profile RNG15_RFL8_NIR8 with 128 pixels x 16 columns expects 8448",
                0},
        Capture{"OS-1-32-G_v2.1.1_1024x10.pcap", "windowed_frame1_0.json", -1,
                "none on the metadata's lidar port 53750 or IMU port 7503", 0}),
    [](const auto& info) { return test_name(info.param); });

}  // namespace
}  // namespace fuse::io

namespace fuse::io {
namespace {

std::uint32_t le32(const std::uint8_t* p) { return std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 | std::uint32_t{p[2]} << 16 | std::uint32_t{p[3]} << 24; }

// One pixel by hand: the raw bytes of the first packet of the OS-2-128 capture
// (RNG19_RFL8_SIG16_NIR16: 32-byte header, columns of 12 + 128 x 12 bytes), the documented
// projection with this sensor's beam angles, then lidar_to_sensor; and the extrinsic.
TEST(OusterProjection, OnePixelByHandAndTheExtrinsic) {
  const std::string pcap = data("OS-2-128-U1_v2.3.0_1024x10.pcap"), json = data("OS-2-128-U1_v2.3.0_1024x10.json");
  FUSE_REQUIRE_SHARED(pcap);
  pcap::PcapReader reader(pcap);
  pcap::UdpDatagram d;
  do {
    ASSERT_TRUE(reader.next(d));
  } while (d.dst_port != 7502);
  ASSERT_EQ(d.payload.size(), 24832u);
  constexpr int kColumn = 5, kBeam = 40;
  const std::uint8_t* col = d.payload.data() + 32 + kColumn * (12 + 128 * 12);
  const int mid = col[8] | col[9] << 8;
  const std::uint32_t range = le32(col + 12 + kBeam * 12) & 0x7FFFF;
  ASSERT_GT(range, 0u) << "choose a pixel with a return";

  // This sensor's numbers, read here from the JSON text independently of the parser.
  const ouster::Metadata meta = ouster::load_metadata(json);
  const double alt = meta.beam_altitude_deg[kBeam] * M_PI / 180.0, az = -meta.beam_azimuth_deg[kBeam] * M_PI / 180.0;
  const double n = 13.762;  // lidar_origin_to_beam_origin_mm in the file
  EXPECT_DOUBLE_EQ(meta.lidar_origin_to_beam_origin_mm, n);
  const double enc = 2.0 * M_PI * (1.0 - mid / 1024.0);
  const Eigen::Vector3d p_lidar((range - n) * std::cos(enc + az) * std::cos(alt) + n * std::cos(enc),
                                (range - n) * std::sin(enc + az) * std::cos(alt) + n * std::sin(enc),
                                (range - n) * std::sin(alt));
  // lidar_to_sensor_transform of the file: [-1 0 0 0; 0 -1 0 0; 0 0 1 78.296] (mm).
  EXPECT_TRUE(meta.lidar_to_sensor.isApprox((Eigen::Matrix4d() << -1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1, 78.296, 0, 0, 0, 1).finished()));
  const Eigen::Vector3d p_sensor = Eigen::Vector3d(-p_lidar.x(), -p_lidar.y(), p_lidar.z() + 78.296) * 1e-3;

  OusterPcapSource source(OusterPcapConfig{pcap, json, {}, {}});
  SensorEvent ev;
  LidarScan scan;
  while (source.next(ev)) {
    if (ev.kind == SensorEvent::Kind::kLidar) {
      scan = ev.scan;
      break;
    }
  }
  ASSERT_FALSE(scan.points.empty());
  double best = 1e9;
  const LidarPoint* found = nullptr;
  for (const auto& p : scan.points) {
    if (p.ring != kBeam) continue;
    const double e = (Eigen::Vector3d(p.x, p.y, p.z) - p_sensor).norm();
    if (e < best) {
      best = e;
      found = &p;
    }
  }
  ASSERT_NE(found, nullptr);
  EXPECT_LT(best, 1e-5) << "the decoded point is the hand-computed one (float precision)";
  EXPECT_NEAR(found->t_rel, static_cast<double>((mid - 0)) / 1024.0 * 0.1, 2e-3) << "column " << mid << "'s time";

  // T_imu_lidar of the source (scans are in the sensor frame) = inv(imu_to_sensor), metres;
  // the point in the IMU frame equals inv(imu_to_sensor) * lidar_to_sensor * p_lidar.
  ASSERT_TRUE(source.T_imu_lidar().has_value());
  const Eigen::Isometry3d T = *source.T_imu_lidar();
  // imu_to_sensor_transform of the file: identity rotation, translation (6.253, -11.775, 11.645) mm.
  EXPECT_TRUE(T.translation().isApprox(Eigen::Vector3d(-6.253e-3, 11.775e-3, -11.645e-3), 1e-9));
  EXPECT_TRUE(T.linear().isApprox(Eigen::Matrix3d::Identity()));
  const Eigen::Vector3d via_lidar = meta.T_imu_lidar() * (p_lidar * 1e-3);
  EXPECT_LT((T * p_sensor - via_lidar).norm(), 1e-9);
}

// Two sensors on the same ports: each metadata takes its own sensor's packets and refuses the
// other's (by packet size / header identification), IMU packets follow their sender's address.
struct SamePorts {
  const char* pcap;
  const char* metadata;
  int lidar_packets;
  int imu;
  std::map<std::string, std::uint64_t> refused;  ///< reason -> count (subset of the stats)
  const char* error;
};

class OusterSamePorts : public ::testing::TestWithParam<SamePorts> {};

TEST_P(OusterSamePorts, SplitIntoTheirSensors) {
  const SamePorts& c = GetParam();
  FUSE_REQUIRE_SHARED(data(c.pcap));
  Replay r = replay(data(c.pcap), data(c.metadata));
  EXPECT_NE(r.error.find(c.error), std::string::npos) << r.error;
  if (c.lidar_packets < 0) return;
  ASSERT_TRUE(r.source);
  EXPECT_EQ(static_cast<int>(r.source->stream().lidar_packets()), c.lidar_packets);
  EXPECT_EQ(static_cast<int>(r.imu.size()), c.imu);
  for (const auto& [reason, n] : c.refused) {
    ASSERT_TRUE(r.stats.rejected.count(reason)) << reason;
    EXPECT_EQ(r.stats.rejected.at(reason), n) << reason;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Ouster, OusterSamePorts,
    ::testing::Values(
        // Legacy 128 beams (24896-byte packets) and legacy 64 beams (12608) on port 7502.
        SamePorts{"same_ports_legacy.pcap", "same_ports_legacy.1.json", 1, 0, {{ouster::reject::kLidarSize, 1}}, "no full frame in 1 lidar packets"},
        SamePorts{"same_ports_legacy.pcap", "same_ports_legacy.2.json", 1, 0, {{ouster::reject::kLidarSize, 1}}, "no full frame in 1 lidar packets"},
        // Sensor 2 (dual return, 64 beams) and sensor 1 (FUSA profile) send packets of the same
        // size: the header's packet type / identification tells them apart; IMU by address.
        SamePorts{"same_ports_nonlegacy.pcap", "same_ports_nonlegacy.2.json", 1, 1,
                  {{ouster::reject::kPacketType, 1}, {ouster::reject::kOtherSensorImu, 1}}, "no full frame in 1 lidar packets"},
        // Its IMU on port 7503 (not in the capture): the 48-byte packets on 7502 are not its lidar packets.
        SamePorts{"same_ports_nonlegacy.pcap", "same_ports_nonlegacy.2.non_colliding_imu.json", 1, 0,
                  {{ouster::reject::kLidarSize, 2}, {ouster::reject::kPacketType, 1}}, "no full frame in 1 lidar packets"},
        SamePorts{"same_ports.pcap", "same_ports.2.json", 1, 1,
                  {{ouster::reject::kLidarSize, 1}, {ouster::reject::kOtherSensorImu, 1}}, "no full frame in 1 lidar packets"},
        SamePorts{"same_ports.pcap", "same_ports.1.json", -1, 0, {}, "'FUSA_RNG15_RFL8_NIR8_DUAL', a lidar packet profile not read here"},
        SamePorts{"same_ports_nonlegacy.pcap", "same_ports_nonlegacy.1.json", -1, 0, {}, "not read here"}),
    [](const auto& info) {
      std::string n = std::string(info.param.metadata);
      for (char& ch : n) {
        if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
      }
      return n;
    });

// Every metadata file parses (both layouts) or names the field that stops it.
TEST(OusterMetadata, EveryFileOfTheDataParsesOrNamesTheField) {
  const std::string dir = data("");
  FUSE_REQUIRE_SHARED(dir);
  const std::map<std::string, std::string> refused = {
      {"OS-1-64_sensor_config_reduced.json", "lidar_origin_to_beam_origin_mm' is missing"},
      {"OS-1-128_767798045_1024x10_20230712_120049.json", "FUSA_RNG15_RFL8_NIR8_DUAL"},
      {"same_ports.1.json", "FUSA_RNG15_RFL8_NIR8_DUAL"},
      {"same_ports_nonlegacy.1.json", "FUSA_RNG15_RFL8_NIR8_DUAL"},
      {"imu_zm_no_lidar_0.json", "RNG19_RFL8_SIG16_NIR16_ZONE16"},
      {"shot_limiting_test.json", "ACCEL32_GYRO32_NMEA"}};
  int parsed = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (e.path().extension() != ".json" || name.find("digest") != std::string::npos) continue;
    auto it = refused.find(name);
    if (it == refused.end()) {
      const ouster::Metadata m = ouster::load_metadata(e.path().string());
      EXPECT_EQ(m.beam_altitude_deg.size(), static_cast<std::size_t>(m.pixels_per_column)) << name;
      EXPECT_GT(m.columns_per_frame, 0) << name;
      ++parsed;
    } else {
      try {
        ouster::load_metadata(e.path().string());
        ADD_FAILURE() << name << " parsed";
      } catch (const InputError& err) {
        EXPECT_NE(std::string(err.what()).find(it->second), std::string::npos) << err.what();
      }
    }
  }
  EXPECT_GE(parsed, 20);
}

struct BadMetadata {
  const char* name;
  const char* edit_from;  ///< text replaced (its last occurrence) in a valid nested-layout file
  const char* edit_to;
  const char* message;
};

class OusterBadMetadata : public ::testing::TestWithParam<BadMetadata> {};

TEST_P(OusterBadMetadata, NamesTheField) {
  const std::string path = data("OS-0-128_v3.0.1_1024x10.json");
  FUSE_REQUIRE_SHARED(path);
  std::ifstream f(path);
  std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const auto at = text.rfind(GetParam().edit_from);  // the last one: lidar_data_format comes after config_params
  ASSERT_NE(at, std::string::npos) << GetParam().edit_from;
  text.replace(at, std::string(GetParam().edit_from).size(), GetParam().edit_to);
  try {
    ouster::parse_metadata(text, "edited.json");
    FAIL() << "parsed";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(GetParam().message), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("edited.json"), std::string::npos) << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(
    Edits, OusterBadMetadata,
    ::testing::Values(BadMetadata{"not_json", "{", "[", "not valid JSON"},
                      BadMetadata{"mode", "\"lidar_mode\": \"1024x10\"", "\"lidar_mode\": \"fast\"", "field 'config_params.lidar_mode' is 'fast'"},
                      BadMetadata{"ppc", "\"pixels_per_column\": 128", "\"pixels_per_column\": 64", "field 'lidar_data_format.pixels_per_column'"},
                      BadMetadata{"angles", "\"beam_altitude_angles\": ", "\"beam_altitude_angles\": 5, \"x\": ", "field 'beam_intrinsics.beam_altitude_angles' is not an array"},
                      BadMetadata{"transform", "\"lidar_to_sensor_transform\"", "\"lidar_to_sensor_transform_x\"", "field 'lidar_intrinsics.lidar_to_sensor_transform or lidar_to_sensor_transform' is missing"},
                      BadMetadata{"profile", "\"LEGACY\",\n        \"udp_profile_lidar\": \"RNG19_RFL8_SIG16_NIR16_DUAL\"\n    },", "\"LEGACY\",\n        \"udp_profile_lidar\": \"XYZ\"\n    },", "'XYZ', a lidar packet profile not read here"}),
    [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace fuse::io

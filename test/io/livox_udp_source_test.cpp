// The live Livox source on loopback: packets built from the protocol document (every data type,
// IMU on its own port) are sent to free ports; the source gives the IMU in SI units, the points
// with their own times grouped into 0.1 s scans, and counts malformed packets and queue overflow.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "fuse/io/livox_udp_source.hpp"
#include "livox_test_packets.hpp"

namespace fuse::io {
namespace {

namespace tp = fuse::test::livox;
using namespace std::chrono_literals;

class UdpSender {
 public:
  UdpSender() : fd_(::socket(AF_INET, SOCK_DGRAM, 0)) {}
  ~UdpSender() { ::close(fd_); }
  void send(std::uint16_t port, const std::vector<std::uint8_t>& bytes) {
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(port);
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::sendto(fd_, bytes.data(), bytes.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof(to)),
              static_cast<ssize_t>(bytes.size()));
  }

 private:
  int fd_;
};

LivoxUdpConfig loopback(double idle_timeout_s) {
  LivoxUdpConfig c;
  c.address = "127.0.0.1";
  c.point_port = 0;  // free ports
  c.imu_port = 0;
  c.idle_timeout_s = idle_timeout_s;
  return c;
}

bool wait_packets(const LivoxUdpSource& s, std::uint64_t n) {
  const auto end = std::chrono::steady_clock::now() + 10s;
  while (std::chrono::steady_clock::now() < end) {
    if (s.packets() >= n) return true;
    std::this_thread::sleep_for(5ms);
  }
  return false;
}

TEST(LivoxUdpSource, DefaultPortsAreTheSdkOnes) {
  LivoxUdpConfig c;
  EXPECT_EQ(c.point_port, 56301);
  EXPECT_EQ(c.imu_port, 56401);
  EXPECT_DOUBLE_EQ(c.scan_period_s, 0.1);
}

TEST(LivoxUdpSource, PointsImuAndScansOverLoopback) {
  LivoxUdpSource source(loopback(0.5));
  UdpSender sender;
  constexpr std::uint64_t kT0Ns = 1'700'000'000'000'000'000ull;
  constexpr double kT0 = 1'700'000'000.0;
  constexpr int kPackets = 25;              // 0.25 s of points
  constexpr int kPointsPerPacket = 96;
  constexpr std::uint16_t kInterval = 100;  // 10 us per packet between first and last... (0.1 us units)
  constexpr double kPacketPeriod = 0.01;
  struct Expected {
    double x, y, z, t;
    int type;
  };
  std::vector<Expected> expected;
  int imu_sent = 0;
  for (int k = 0; k < kPackets; ++k) {
    const std::uint8_t type = static_cast<std::uint8_t>(1 + k % 3);  // every point data type in turn
    const std::uint64_t ts = kT0Ns + static_cast<std::uint64_t>(k) * 10'000'000ull;
    std::vector<tp::RawPoint> pts;
    for (int i = 0; i < kPointsPerPacket; ++i) {
      tp::RawPoint p{1.0 + 0.01 * (i % 50), -2.0 + 0.01 * k, 0.5, static_cast<std::uint8_t>(i), 0};
      pts.push_back(p);
      expected.push_back({p.x, p.y, p.z, kT0 + k * kPacketPeriod + i * kInterval * 1e-7 / kPointsPerPacket, type});
    }
    sender.send(source.point_port(), tp::packet(type, kPointsPerPacket, kInterval, ts, tp::point_data(type, pts)));
    // Two IMU samples per point packet (200 Hz): 0.1 rad/s about z, 1 g along z.
    for (int j = 0; j < 2; ++j) {
      sender.send(source.imu_port(), tp::packet(0, 1, 0, ts + j * 5'000'000ull, tp::imu_data(0, 0, 0.1f, 0, 0, 1.0f)));
      ++imu_sent;
    }
    std::this_thread::sleep_for(1ms);
  }
  // Malformed: short, wrong length field, bad version, unknown data type.
  const auto good = tp::packet(1, 1, 0, kT0Ns, tp::point_data(1, {{1, 1, 1}}));
  sender.send(source.point_port(), std::vector<std::uint8_t>(good.begin(), good.begin() + 12));
  sender.send(source.point_port(), tp::packet(1, 1, 0, kT0Ns, tp::point_data(1, {{1, 1, 1}}), 0, 40));
  sender.send(source.point_port(), tp::packet(1, 1, 0, kT0Ns, tp::point_data(1, {{1, 1, 1}}), 9));
  sender.send(source.imu_port(), tp::packet(9, 1, 0, kT0Ns, tp::imu_data(0, 0, 0, 0, 0, 1)));

  std::vector<ImuSample> imu;
  std::vector<LidarScan> scans;
  SensorEvent ev;
  while (source.next(ev)) {  // ends 0.5 s after the last packet
    if (ev.kind == SensorEvent::Kind::kImu) {
      imu.push_back(ev.imu);
    } else {
      scans.push_back(ev.scan);
    }
  }
  EXPECT_EQ(source.packets(), static_cast<std::uint64_t>(kPackets + imu_sent + 4));
  EXPECT_EQ(source.malformed(), 4u);
  const auto& rejected = source.stats().rejected;
  for (const char* r : {livox::reject::kShort, livox::reject::kLengthMismatch, livox::reject::kBadVersion,
                        livox::reject::kUnknownDataType}) {
    EXPECT_EQ(rejected.count(r) ? rejected.at(r) : 0u, 1u) << r;
  }

  ASSERT_EQ(imu.size(), static_cast<std::size_t>(imu_sent));
  for (std::size_t i = 0; i < imu.size(); ++i) {
    EXPECT_NEAR(imu[i].t, kT0 + 0.005 * static_cast<double>(i), 1e-6);
    EXPECT_NEAR(imu[i].accel.z(), 9.80665, 1e-6);
    EXPECT_NEAR(imu[i].gyro.z(), 0.1, 1e-6);
  }

  // 0.25 s of points: [0, 0.1) and [0.1, 0.2) complete, then the rest at the end of the stream.
  ASSERT_EQ(scans.size(), 3u);
  std::size_t n = 0;
  for (std::size_t k = 0; k < scans.size(); ++k) {
    EXPECT_NEAR(scans[k].t_start, kT0 + 0.1 * static_cast<double>(k), 1e-6);
    if (k < 2) {
      EXPECT_NEAR(scans[k].t_end - scans[k].t_start, 0.1, 1e-6);  // times near 1.7e9 s: ~2e-7 s resolution
    }
    for (const auto& p : scans[k].points) {
      ASSERT_LT(n, expected.size());
      const Expected& e = expected[n++];
      const double tol = e.type == 3 ? 1e-3 + 3.0 * 0.01 * M_PI / 180.0 : 1e-5;  // spherical: quantised angles
      EXPECT_NEAR(p.x, e.x, tol) << n;
      EXPECT_NEAR(p.y, e.y, tol) << n;
      EXPECT_NEAR(p.z, e.z, tol) << n;
      EXPECT_NEAR(scans[k].t_start + p.t_rel, e.t, 1e-6) << "point " << n << " keeps its own time";
    }
  }
  EXPECT_EQ(n, expected.size()) << "every point arrives once";
}

TEST(LivoxUdpSource, FullQueueIsCountedNotSilent) {
  auto config = loopback(0.3);
  config.queue_capacity = 5;
  LivoxUdpSource source(config);
  UdpSender sender;
  constexpr int kSent = 20;
  for (int i = 0; i < kSent; ++i) {
    sender.send(source.imu_port(), tp::packet(0, 1, 0, 5'000'000ull * (i + 1), tp::imu_data(0, 0, 0, 0, 0, 1)));
  }
  ASSERT_TRUE(wait_packets(source, kSent));
  std::this_thread::sleep_for(100ms);  // handled before anything is taken out
  SensorEvent ev;
  int got = 0;
  while (source.next(ev)) ++got;
  EXPECT_EQ(got, 5);
  EXPECT_EQ(source.stats().rejected.at(livox_reason::kQueueOverflow), static_cast<std::uint64_t>(kSent - 5));
}

TEST(LivoxUdpSource, StopEndsTheStreamAndBadConfigIsRefused) {
  LivoxUdpSource source(loopback(0.0));  // no idle timeout: only stop() ends it
  std::thread stopper([&] {
    std::this_thread::sleep_for(200ms);
    source.stop();
  });
  SensorEvent ev;
  EXPECT_FALSE(source.next(ev));
  stopper.join();
  std::atomic<bool> flag{false};
  auto hooked = loopback(0.0);
  hooked.should_stop = [&flag] { return flag.load(); };
  LivoxUdpSource polled(hooked);
  std::thread setter([&] {
    std::this_thread::sleep_for(200ms);
    flag = true;
  });
  EXPECT_FALSE(polled.next(ev));
  setter.join();
  auto bad = loopback(0.0);
  bad.address = "not-an-address";
  EXPECT_THROW(LivoxUdpSource{bad}, InputError);
  auto busy = loopback(0.0);
  busy.point_port = source.point_port();  // held by `source`
  EXPECT_THROW(LivoxUdpSource{busy}, InputError);
  auto same = loopback(0.0);
  same.point_port = same.imu_port = 56999;
  EXPECT_THROW(LivoxUdpSource{same}, InputError);
}

}  // namespace
}  // namespace fuse::io

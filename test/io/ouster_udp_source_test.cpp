// Live Ouster input over loopback: the packets of a real capture (the 3-frame OS-1-128
// low-bandwidth one) are sent to the live source's sockets (ports 0: free ones, overriding the
// metadata's) and must give what the pcap replay of the same capture gives: the same scans
// (times, points) and IMU samples. Plus: a port the metadata sets to 0 is not listened on, a
// stop predicate ends a blocked next(), and a busy port is a clear error.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "fuse/io/ouster_pcap_source.hpp"
#include "fuse/io/ouster_udp_source.hpp"
#include "fuse/io/pcap_reader.hpp"
#include "test_util.hpp"

namespace fuse::io {
namespace {

using namespace std::chrono_literals;

void send_to(int fd, std::uint16_t port, const std::vector<std::uint8_t>& bytes) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(port);
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::sendto(fd, bytes.data(), bytes.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof(to)),
            static_cast<ssize_t>(bytes.size()));
}

std::vector<SensorEvent> drain(SensorSource& s) {
  std::vector<SensorEvent> out;
  SensorEvent ev;
  while (s.next(ev)) out.push_back(ev);
  return out;
}

TEST(OusterUdpSource, ReplayedCaptureOverLoopbackEqualsThePcapReplay) {
  const std::string pcap = test::shared_data("ouster/OS-1-128_v2.3.0_1024x10_lb_n3.pcap");
  const std::string json = test::shared_data("ouster/OS-1-128_v2.3.0_1024x10.json");
  FUSE_REQUIRE_SHARED(pcap);
  OusterPcapSource file(OusterPcapConfig{pcap, json, {}, {}});
  const std::vector<SensorEvent> expected = drain(file);

  OusterUdpConfig config;
  config.metadata = json;
  config.address = "127.0.0.1";
  config.lidar_port = 0;
  config.imu_port = 0;
  config.idle_timeout_s = 1.0;
  OusterUdpSource live(config);
  ASSERT_NE(live.lidar_port(), 0);
  ASSERT_NE(live.imu_port(), 0);
  ASSERT_NE(live.lidar_port(), live.imu_port());

  std::thread sender([&] {
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    pcap::PcapReader reader(pcap);
    pcap::UdpDatagram d;
    while (reader.next(d)) {
      send_to(fd, d.dst_port == 7502 ? live.lidar_port() : live.imu_port(), d.payload);
      std::this_thread::sleep_for(500us);  // paced: loopback drops what the socket buffer cannot hold
    }
    ::close(fd);
  });
  const std::vector<SensorEvent> got = drain(live);
  sender.join();

  ASSERT_EQ(got.size(), expected.size());
  int scans = 0, imu = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    ASSERT_EQ(got[i].kind, expected[i].kind) << i;
    if (got[i].kind == SensorEvent::Kind::kImu) {
      ++imu;
      EXPECT_EQ(got[i].imu.t, expected[i].imu.t);
      EXPECT_EQ(got[i].imu.accel, expected[i].imu.accel);
      EXPECT_EQ(got[i].imu.gyro, expected[i].imu.gyro);
      continue;
    }
    ++scans;
    const LidarScan &a = got[i].scan, &b = expected[i].scan;
    EXPECT_EQ(a.t_start, b.t_start);
    EXPECT_EQ(a.t_end, b.t_end);
    ASSERT_EQ(a.points.size(), b.points.size());
    for (std::size_t k = 0; k < a.points.size(); ++k) {
      ASSERT_EQ(a.points[k].x, b.points[k].x);
      ASSERT_EQ(a.points[k].z, b.points[k].z);
      ASSERT_EQ(a.points[k].t_rel, b.points[k].t_rel);
      ASSERT_EQ(a.points[k].ring, b.points[k].ring);
    }
  }
  EXPECT_EQ(scans, 3);
  EXPECT_EQ(imu, 30);
  EXPECT_EQ(live.packets(), 222u);
  ASSERT_TRUE(live.T_imu_lidar().has_value());
  EXPECT_TRUE(live.T_imu_lidar()->isApprox(*file.T_imu_lidar()));
}

TEST(OusterUdpSource, StopPredicateEndsABlockedNext) {
  const std::string json = test::shared_data("ouster/OS-1-128_v2.3.0_1024x10.json");
  FUSE_REQUIRE_SHARED(json);
  std::atomic<bool> stop{false};
  OusterUdpConfig config;
  config.metadata = json;
  config.address = "127.0.0.1";
  config.lidar_port = 0;
  config.imu_port = 0;
  config.should_stop = [&] { return stop.load(); };
  OusterUdpSource live(config);
  std::thread t([&] {
    std::this_thread::sleep_for(200ms);
    stop = true;
  });
  const auto t0 = std::chrono::steady_clock::now();
  SensorEvent ev;
  EXPECT_FALSE(live.next(ev));
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 2s);
  t.join();
}

TEST(OusterUdpSource, ABusyPortIsAClearError) {
  const std::string json = test::shared_data("ouster/OS-1-128_v2.3.0_1024x10.json");
  FUSE_REQUIRE_SHARED(json);
  OusterUdpConfig config;
  config.metadata = json;
  config.address = "127.0.0.1";
  config.lidar_port = 0;
  config.imu_port = 0;
  OusterUdpSource first(config);
  config.lidar_port = first.lidar_port();
  try {
    OusterUdpSource second(config);
    FAIL() << "bound a busy port";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("lidar port 127.0.0.1:" + std::to_string(first.lidar_port())),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace fuse::io

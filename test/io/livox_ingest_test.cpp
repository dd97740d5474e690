// fuse-ingest --livox-udp as a real process: Livox SDK2 packets built from the protocol document
// (livox_test_packets.hpp) sent over loopback reach the DDS topics `imu` (m/s^2) and `lidar/scan`
// (0.1 s scans, every point once), and SIGTERM stops it cleanly while it waits for packets.
// DDS domain 101 (shared with the record/replay test: both run serially). Also fuse-ingest on an
// Ouster pcap capture with its metadata (the same domain, one after the other): 3 scans and 30 IMU samples on the topics.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>

#include "fuse/io/pcap_reader.hpp"
#include "fuse/launch/process.hpp"
#include "fuse/transport/msg_traits.hpp"
#include "fuse/transport/qos.hpp"
#include "livox_test_packets.hpp"

namespace fuse {
namespace {

namespace tp = fuse::test::livox;
using namespace std::chrono_literals;

constexpr int kDomain = 101;
constexpr int kOusterDomain = kDomain;  // 102..109 are beyond the DDS limit of 101: serial tests share it

/// A UDP port free right now (bound to port 0, read back, released).
std::uint16_t free_port() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr));
  socklen_t len = sizeof(addr);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  ::close(fd);
  return ntohs(addr.sin_port);
}

void send_to(int fd, std::uint16_t port, const std::vector<std::uint8_t>& bytes) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(port);
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ::sendto(fd, bytes.data(), bytes.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof(to));
}

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

TEST(LivoxIngest, PacketsOverLoopbackReachTheDdsTopics) {
  const std::string out = std::string(FUSE_TEST_OUT) + "/livox_ingest";
  std::filesystem::create_directories(out);
  const std::string log = out + "/fuse-ingest.log";
  std::filesystem::remove(log);
  const std::uint16_t point_port = free_port(), imu_port = free_port();

  transport::TransportConfig tc;
  tc.domain_id = kDomain;
  auto participant = transport::make_participant(tc, "test-livox-ingest");
  std::mutex mutex;
  std::vector<fuse_msgs::ImuSample> imu;
  std::vector<fuse_msgs::LidarScan> scans;
  transport::Subscriber<fuse_msgs::ImuSample> imu_sub(*participant, transport::topics::kImu, [&](const auto& m) {
    std::lock_guard<std::mutex> lock(mutex);
    imu.push_back(m);
  });
  transport::Subscriber<fuse_msgs::LidarScan> scan_sub(*participant, transport::topics::kLidarScan, [&](const auto& m) {
    std::lock_guard<std::mutex> lock(mutex);
    scans.push_back(m);
  });

  auto ingest = launch::Process::spawn(
      {std::string(FUSE_BIN_DIR) + "/fuse-ingest", "--config", std::string(FUSE_CONFIG_DIR) + "/mid360.yaml", "--set",
       "transport.domain_id=" + std::to_string(kDomain), "--set", "ingest.start_wait_s=0.5", "--livox-udp",
       "127.0.0.1:" + std::to_string(point_port) + ":" + std::to_string(imu_port)},
      log);
  // Ready once it listens and our readers are matched to its writers.
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (std::chrono::steady_clock::now() < deadline &&
         (read_text(log).find("listening for Livox") == std::string::npos || imu_sub.matched() == 0 ||
          scan_sub.matched() == 0)) {
    std::this_thread::sleep_for(50ms);
  }
  ASSERT_GT(scan_sub.matched(), 0u) << read_text(log);
  std::this_thread::sleep_for(1s);  // past its start wait

  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  constexpr std::uint64_t kT0Ns = 50'000'000'000ull;  // 50 s after power-on (time_type 0)
  constexpr int kPackets = 35, kPoints = 96;          // 0.35 s: scans [0, 0.1), [0.1, 0.2), [0.2, 0.3)
  int imu_sent = 0;
  for (int k = 0; k < kPackets; ++k) {
    const std::uint64_t ts = kT0Ns + static_cast<std::uint64_t>(k) * 10'000'000ull;
    std::vector<tp::RawPoint> pts;
    for (int i = 0; i < kPoints; ++i) pts.push_back({2.0 + 0.01 * i, 1.0, -0.5, 50, 0});
    for (int j = 0; j < 2; ++j) {
      send_to(fd, imu_port, tp::packet(0, 1, 0, ts + j * 5'000'000ull, tp::imu_data(0.01f, 0, 0, 0, 0, 1.0f)));
      ++imu_sent;
    }
    send_to(fd, point_port, tp::packet(1, kPoints, 1000, ts, tp::point_data(1, pts)));
    std::this_thread::sleep_for(2ms);
  }
  send_to(fd, point_port, std::vector<std::uint8_t>(10, 0));  // malformed: counted, not fatal
  ::close(fd);

  const auto wait_end = std::chrono::steady_clock::now() + 20s;
  while (std::chrono::steady_clock::now() < wait_end) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (static_cast<int>(imu.size()) >= imu_sent && scans.size() >= 3) break;
    }
    std::this_thread::sleep_for(20ms);
  }
  const auto t = ingest.terminate(10s);
  EXPECT_FALSE(t.escalated) << "SIGTERM stops it while it waits for packets";
  EXPECT_EQ(t.status.code, 0) << read_text(log);

  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_EQ(imu.size(), static_cast<std::size_t>(imu_sent)) << read_text(log);
  for (std::size_t i = 0; i < imu.size(); ++i) {
    EXPECT_NEAR(imu[i].t(), 50.0 + 0.005 * static_cast<double>(i), 1e-9);
    EXPECT_NEAR(imu[i].accel().z(), 9.80665, 1e-6);
    EXPECT_NEAR(imu[i].gyro().x(), 0.01, 1e-6);
  }
  ASSERT_GE(scans.size(), 3u) << read_text(log);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(scans[k].start_time(), 50.0 + 0.1 * static_cast<double>(k), 1e-9);
    EXPECT_NEAR(scans[k].end_time() - scans[k].start_time(), 0.1, 1e-9);
    EXPECT_EQ(scans[k].points().size(), static_cast<std::size_t>(10 * kPoints)) << "ten packets a scan";
  }
  EXPECT_NE(read_text(log).find("livox_short_packet"), std::string::npos) << "the malformed packet is reported";
}

TEST(OusterIngest, PcapCaptureReachesTheDdsTopics) {
  const std::string data = std::string(FUSE_SHARED_DATA) + "/ouster/";
  if (!std::filesystem::exists(data + "OS-1-128_v2.3.0_1024x10_lb_n3.pcap")) {
    GTEST_SKIP() << "shared test data not found at " << data << " (FUSE_SHARED_DATA)";
  }
  const std::string out = std::string(FUSE_TEST_OUT) + "/ouster_ingest";
  std::filesystem::create_directories(out);
  const std::string log = out + "/fuse-ingest.log";
  std::filesystem::remove(log);
  transport::TransportConfig tc;
  tc.domain_id = kOusterDomain;
  auto participant = transport::make_participant(tc, "test-ouster-ingest");
  std::mutex mutex;
  std::vector<fuse_msgs::ImuSample> imu;
  std::vector<fuse_msgs::LidarScan> scans;
  transport::Subscriber<fuse_msgs::ImuSample> imu_sub(*participant, transport::topics::kImu, [&](const auto& m) {
    std::lock_guard<std::mutex> lock(mutex);
    imu.push_back(m);
  });
  transport::Subscriber<fuse_msgs::LidarScan> scan_sub(*participant, transport::topics::kLidarScan, [&](const auto& m) {
    std::lock_guard<std::mutex> lock(mutex);
    scans.push_back(m);
  });
  // Lockstep (no fuse-update here: each scan waits 0.2 s for an answer, then goes on), so no
  // event is skipped as behind a real-time schedule; it starts after the start wait, once our
  // readers are matched.
  auto ingest = launch::Process::spawn(
      {std::string(FUSE_BIN_DIR) + "/fuse-ingest", "--config", std::string(FUSE_CONFIG_DIR) + "/spinning.yaml", "--set",
       "transport.domain_id=" + std::to_string(kOusterDomain), "--set", "ingest.start_wait_s=3", "--set", "ingest.lockstep_timeout_s=0.2", "--mode", "lockstep",
       "--input", data + "OS-1-128_v2.3.0_1024x10_lb_n3.pcap", "--ouster-metadata", data + "OS-1-128_v2.3.0_1024x10.json"},
      log);
  const auto status = ingest.wait_for(60s);
  ASSERT_TRUE(status.has_value()) << read_text(log);
  EXPECT_EQ(status->code, 0) << read_text(log);
  const auto wait_end = std::chrono::steady_clock::now() + 5s;
  while (std::chrono::steady_clock::now() < wait_end) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (imu.size() >= 30 && scans.size() >= 3) break;
    }
    std::this_thread::sleep_for(20ms);
  }
  std::lock_guard<std::mutex> lock(mutex);
  EXPECT_EQ(imu.size(), 30u) << read_text(log);
  ASSERT_EQ(scans.size(), 3u) << read_text(log);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(scans[k].end_time() - scans[k].start_time(), 0.0999, 0.001);
    EXPECT_GT(scans[k].points().size(), 50000u);
    if (k > 0) {
      EXPECT_NEAR(scans[k].start_time() - scans[k - 1].start_time(), 0.1, 0.002);
    }
  }
  for (std::size_t i = 1; i < imu.size(); ++i) {
    EXPECT_NEAR(imu[i].t() - imu[i - 1].t(), 0.01, 0.002);
  }
  EXPECT_NE(read_text(log).find("replay done: 30 IMU samples, 3 scans"), std::string::npos) << read_text(log);
}

// fuse-ingest --ouster-udp: the 3-frame OS-1-128 capture's packets sent over loopback to the
// ports given on the command line (overriding the metadata's 7502/7503) reach the topics.
TEST(OusterIngest, LiveUdpPacketsReachTheDdsTopics) {
  const std::string data = std::string(FUSE_SHARED_DATA) + "/ouster/";
  const std::string pcap = data + "OS-1-128_v2.3.0_1024x10_lb_n3.pcap";
  if (!std::filesystem::exists(pcap)) GTEST_SKIP() << "shared test data not found at " << data << " (FUSE_SHARED_DATA)";
  const std::string out = std::string(FUSE_TEST_OUT) + "/ouster_udp_ingest";
  std::filesystem::create_directories(out);
  const std::string log = out + "/fuse-ingest.log";
  std::filesystem::remove(log);
  const std::uint16_t lidar_port = free_port(), imu_port = free_port();
  transport::TransportConfig tc;
  tc.domain_id = kOusterDomain;
  auto participant = transport::make_participant(tc, "test-ouster-udp-ingest");
  std::mutex mutex;
  std::vector<fuse_msgs::ImuSample> imu;
  std::vector<fuse_msgs::LidarScan> scans;
  transport::Subscriber<fuse_msgs::ImuSample> imu_sub(*participant, transport::topics::kImu, [&](const auto& m) {
    std::lock_guard<std::mutex> lock(mutex);
    imu.push_back(m);
  });
  transport::Subscriber<fuse_msgs::LidarScan> scan_sub(*participant, transport::topics::kLidarScan, [&](const auto& m) {
    std::lock_guard<std::mutex> lock(mutex);
    scans.push_back(m);
  });
  auto ingest = launch::Process::spawn(
      {std::string(FUSE_BIN_DIR) + "/fuse-ingest", "--config", std::string(FUSE_CONFIG_DIR) + "/spinning.yaml", "--set",
       "transport.domain_id=" + std::to_string(kOusterDomain), "--set", "ingest.start_wait_s=0.5", "--ouster-udp",
       "127.0.0.1:" + std::to_string(lidar_port) + ":" + std::to_string(imu_port), "--ouster-metadata",
       data + "OS-1-128_v2.3.0_1024x10.json"},
      log);
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (std::chrono::steady_clock::now() < deadline &&
         (read_text(log).find("listening for Ouster") == std::string::npos || imu_sub.matched() == 0 ||
          scan_sub.matched() == 0)) {
    std::this_thread::sleep_for(50ms);
  }
  ASSERT_GT(scan_sub.matched(), 0u) << read_text(log);
  std::this_thread::sleep_for(1s);  // past its start wait

  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  io::pcap::PcapReader reader(pcap);
  io::pcap::UdpDatagram d;
  while (reader.next(d)) {
    send_to(fd, d.dst_port == 7502 ? lidar_port : imu_port, d.payload);
    std::this_thread::sleep_for(1ms);  // paced like the sensor (~0.3 s for the capture)
  }
  ::close(fd);
  const auto wait_end = std::chrono::steady_clock::now() + 20s;
  while (std::chrono::steady_clock::now() < wait_end) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      // The last events are released once the input has been quiet for 50 ms.
      if (imu.size() >= 30 && scans.size() >= 3) break;
    }
    std::this_thread::sleep_for(20ms);
  }
  const auto t = ingest.terminate(10s);
  EXPECT_FALSE(t.escalated) << "SIGTERM stops it while it waits for packets";
  EXPECT_EQ(t.status.code, 0) << read_text(log);
  std::lock_guard<std::mutex> lock(mutex);
  EXPECT_EQ(imu.size(), 30u) << read_text(log);
  ASSERT_EQ(scans.size(), 3u) << read_text(log);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_NEAR(scans[k].end_time() - scans[k].start_time(), 0.0999, 0.001);
  }
}

}  // namespace
}  // namespace fuse

// Bad input on the wire: samples with NaN, wrong sizes, out-of-order or duplicate times, and bad
// query requests reach real fuse-state and fuse-update processes; each is counted and reported
// on the health topic (or answered with a typed error) and neither service crashes.
// DDS domain 65 belongs to this file.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <map>
#include <mutex>
#include <thread>

#include "fuse/launch/process.hpp"
#include "fuse/transport/rpc.hpp"

namespace fuse {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;
constexpr int kDomain = 65;
const std::string kConfig = std::string(FUSE_CONFIG_DIR) + "/mid360.yaml";

fuse_msgs::ImuSample imu(double t, double gz = 0.0) {
  fuse_msgs::ImuSample m;
  m.t(t);
  fuse_msgs::Vector3 a;
  a.z(9.81);
  m.accel(a);
  fuse_msgs::Vector3 g;
  g.z(gz);
  m.gyro(g);
  return m;
}

fuse_msgs::LidarScan scan(double t0, double t1, std::size_t n, float offset = 0.0f) {
  fuse_msgs::LidarScan m;
  m.start_time(t0);
  m.end_time(t1);
  m.points().resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    m.points()[i].x(5.0f);
    m.points()[i].time_offset(offset);
  }
  return m;
}

class WireInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::string(FUSE_TEST_OUT) + "/wire-input";
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    const std::vector<std::string> common{"--config", kConfig, "--set", "transport.domain_id=" + std::to_string(kDomain),
                                          "--set", "health.period_s=0.1", "--set", "update.map_sync_timeout_s=0.5"};
    auto args = [&](const std::string& name) {
      std::vector<std::string> a{std::string(FUSE_BIN_DIR) + "/" + name};
      a.insert(a.end(), common.begin(), common.end());
      return a;
    };
    state_.emplace(launch::Process::spawn(args("fuse-state"), dir_ + "/fuse-state.log"));
    update_.emplace(launch::Process::spawn(args("fuse-update"), dir_ + "/fuse-update.log"));
    transport::TransportConfig tc;
    tc.domain_id = kDomain;
    participant_ = transport::make_participant(tc, "test-wire");
    health_ = std::make_unique<transport::Subscriber<fuse_msgs::Health>>(
        *participant_, transport::topics::kHealth, [this](const fuse_msgs::Health& h) {
          std::lock_guard<std::mutex> lock(mutex_);
          auto& counters = counters_[h.service().to_string()];
          for (const auto& c : h.counters()) counters[c.name().to_string()] = c.value();
          states_[h.service().to_string()] = h.state().to_string();
        });
  }
  void TearDown() override {
    health_.reset();
    for (auto* p : {&update_, &state_}) {
      if (*p) (*p)->terminate(5s);
    }
  }

  std::uint64_t counter(const std::string& service, const std::string& name) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto& c = counters_[service];
    auto it = c.find(name);
    return it == c.end() ? 0 : it->second;
  }
  /// Waits until the counter reaches n (health is published every 0.1 s).
  bool wait_counter(const std::string& service, const std::string& name, std::uint64_t n) {
    const auto end = std::chrono::steady_clock::now() + 10s;
    while (std::chrono::steady_clock::now() < end) {
      if (counter(service, name) >= n) return true;
      std::this_thread::sleep_for(20ms);
    }
    return false;
  }
  bool wait_state(const std::string& service, const std::string& state) {
    const auto end = std::chrono::steady_clock::now() + 15s;
    while (std::chrono::steady_clock::now() < end) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (states_[service] == state) return true;
      }
      std::this_thread::sleep_for(20ms);
    }
    return false;
  }

  std::string dir_;
  std::optional<launch::Process> state_, update_;
  std::unique_ptr<transport::Participant> participant_;
  std::mutex mutex_;
  std::map<std::string, std::map<std::string, std::uint64_t>> counters_;
  std::map<std::string, std::string> states_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::Health>> health_;
};

TEST_F(WireInput, BadSamplesAreCountedOnHealthAndNobodyCrashes) {
  // fuse-state leaves "starting" once it has looked for a correction to recover from.
  ASSERT_TRUE(wait_state("fuse-state", "initialising")) << "fuse-state did not come up";
  ASSERT_TRUE(wait_state("fuse-update", "running")) << "fuse-update did not come up";
  transport::Publisher<fuse_msgs::ImuSample> imu_pub(*participant_, transport::topics::kImu);
  transport::Publisher<fuse_msgs::LidarScan> scan_pub(*participant_, transport::topics::kLidarScan);
  auto raw_imu = participant_->create_writer(transport::topics::kImu, transport::type_support<fuse_msgs::ImuSample>(),
                                             transport::topic_qos(transport::topics::kImu));
  auto raw_scan = participant_->create_writer(transport::topics::kLidarScan,
                                              transport::type_support<fuse_msgs::LidarScan>(),
                                              transport::topic_qos(transport::topics::kLidarScan));
  const auto end = std::chrono::steady_clock::now() + 10s;
  while ((imu_pub.matched() == 0 || scan_pub.matched() == 0) && std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(10ms);
  }

  // IMU: good, NaN, duplicate time, going back, wrong size (truncated), garbage.
  imu_pub.publish(imu(10.0));
  imu_pub.publish(imu(10.005, std::nan("")));
  imu_pub.publish(imu(10.01));
  imu_pub.publish(imu(10.01));   // duplicate
  imu_pub.publish(imu(10.0));    // back in time
  transport::Bytes truncated = transport::serialize(imu(10.02));
  truncated.resize(truncated.size() / 2);
  raw_imu->write(truncated);
  raw_imu->write(transport::Bytes(7, 0xAB));
  EXPECT_TRUE(wait_counter("fuse-state", "imu_not_finite", 1));
  EXPECT_TRUE(wait_counter("fuse-state", "imu_duplicate", 1));
  EXPECT_TRUE(wait_counter("fuse-state", "imu_out_of_order", 1));
  EXPECT_TRUE(wait_counter("fuse-state", "malformed_imu", 2));

  // Scans: NaN time, ends before it starts, point times outside the scan, no points, garbage.
  scan_pub.publish(scan(std::nan(""), 10.1, 10));
  scan_pub.publish(scan(10.1, 10.0, 10));
  scan_pub.publish(scan(10.0, 10.1, 10, 5.0f));
  scan_pub.publish(scan(10.0, 10.1, 0));
  raw_scan->write(transport::Bytes(64, 0x11));
  EXPECT_TRUE(wait_counter("fuse-update", "scan_bad_time", 2));
  EXPECT_TRUE(wait_counter("fuse-update", "scan_bad_point_time", 1));
  EXPECT_TRUE(wait_counter("fuse-update", "scan_empty", 1));
  EXPECT_TRUE(wait_counter("fuse-update", "malformed_scan", 1));

  // Query requests for NaN, negative and absurd times get typed errors.
  transport::RpcClient<fuse_msgs::QueryRequest, fuse_msgs::QueryReply> query(*participant_, transport::services::kQuery);
  for (double t : {std::nan(""), -1.0, 1e15}) {
    fuse_msgs::QueryRequest req;
    req.t(t);
    const auto r = query.call(req, 10s);
    EXPECT_EQ(r.status, fuse_msgs::RPC_BAD_REQUEST) << "t=" << t << ": " << r.message;
  }

  EXPECT_TRUE(state_->is_running());
  EXPECT_TRUE(update_->is_running());
}

}  // namespace
}  // namespace fuse

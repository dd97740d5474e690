// fuse::query::Client against a stand-in query server (DDS domain 40): every field of a known
// estimate, host-time queries, the stream of estimates, the statuses, typed errors, client-side rejection of invalid times, the deadline
// with no server (domain 41), option checks, concurrent calls and the scheduler slice of the
// client's transport threads.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <mutex>
#include <vector>
#include <set>
#include <thread>

#include "fuse/core/scheduling.hpp"
#include "fuse/query/client.hpp"
#include "query_server.hpp"
#include "test_helpers.hpp"

namespace fuse::query {
namespace {

namespace qt = test::query_times;
constexpr int kServerDomain = 40;
constexpr int kEmptyDomain = 41;

ClientOptions options(int domain, int deadline_ms = 5000) {
  ClientOptions o;
  o.domain_id = domain;
  o.deadline_ms = deadline_ms;
  return o;
}

void expect_known(const Estimate& e, double t) {
  const auto msg = test::known_estimate(t, fuse_msgs::STATUS_INTERPOLATED);
  EXPECT_EQ(e.t, t);
  EXPECT_EQ(e.position, (std::array<double, 3>{t + 1.0, -2.5, 0.125}));
  EXPECT_EQ(e.orientation_xyzw, (std::array<double, 4>{0.0, 0.0, std::sin(0.25), std::cos(0.25)}));
  EXPECT_EQ(e.velocity, (std::array<double, 3>{0.5, -0.25, t / 1000.0}));
  EXPECT_EQ(e.pose_covariance, msg.pose_covariance());
  EXPECT_EQ(e.velocity_covariance, msg.velocity_covariance());
  EXPECT_EQ(e.angular_velocity, (std::array<double, 3>{t / 100.0, -0.5, 0.25}));
  EXPECT_EQ(e.frame_id, "world");
  EXPECT_EQ(e.child_frame_id, "imu");
  EXPECT_TRUE(e.host_clock.known);
  EXPECT_EQ(e.host_clock.realtime_offset, qt::kRealtimeOffset);
  EXPECT_EQ(e.host_clock.monotonic_offset, qt::kMonotonicOffset);
}

class QueryClient : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { server_ = new test::FakeQueryServer(kServerDomain); }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
  }
  static test::FakeQueryServer* server_;
};
test::FakeQueryServer* QueryClient::server_ = nullptr;

TEST_F(QueryClient, AnswersAKnownEstimateFieldByField) {
  Client client(options(kServerDomain));
  ASSERT_TRUE(client.wait_for_server(10000));
  const Result r = client.at(qt::kInterpolated);
  ASSERT_EQ(r.error, Error::ok) << r.message;
  EXPECT_TRUE(r.ok());
  EXPECT_EQ(r.estimate.status, Status::interpolated);
  expect_known(r.estimate, qt::kInterpolated);
}

// A host time goes to the server with its clock; the answer is on the sensor clock.
TEST_F(QueryClient, AHostTimeIsAskedOnItsClock) {
  Client client(options(kServerDomain));
  ASSERT_TRUE(client.wait_for_server(10000));
  const Result rt = client.at(qt::kInterpolated + qt::kRealtimeOffset, Clock::host_realtime);
  ASSERT_EQ(rt.error, Error::ok) << rt.message;
  expect_known(rt.estimate, qt::kInterpolated);
  const Result mono = client.at(qt::kTooOld + qt::kMonotonicOffset, Clock::host_monotonic);
  EXPECT_EQ(mono.error, Error::out_of_range);
  EXPECT_EQ(mono.estimate.t, qt::kTooOld);
  EXPECT_EQ(client.at(-1.0, Clock::host_realtime).error, Error::bad_request);
}

// Streaming: every estimate published on state/odometry reaches the callback and newest(),
// judged as a reply is (ok only for a tracked pose).
TEST_F(QueryClient, StreamedEstimatesReachTheCallbackAndNewest) {
  std::mutex mutex;  // declared before the client: they outlive a callback in flight
  std::vector<Result> got;
  Client client(options(kServerDomain));
  EXPECT_EQ(client.newest().error, Error::not_ready);
  client.subscribe([&](const Result& r) {
    std::lock_guard<std::mutex> lock(mutex);
    got.push_back(r);
  });
  auto count = [&] {
    std::lock_guard<std::mutex> lock(mutex);
    return got.size();
  };
  // Best effort and discovered in the background: publish until one arrives.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (count() == 0 && std::chrono::steady_clock::now() < deadline) {
    server_->stream(qt::kInterpolated, fuse_msgs::STATUS_PROPAGATED);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  ASSERT_GT(count(), 0u) << "no streamed estimate in 30 s";
  {
    std::lock_guard<std::mutex> lock(mutex);
    ASSERT_TRUE(got.front().ok()) << got.front().message;
    expect_known(got.front().estimate, qt::kInterpolated);
  }
  EXPECT_TRUE(client.newest().ok());
  const std::size_t before = count();
  const auto lost_deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (client.newest().estimate.status != Status::lost && std::chrono::steady_clock::now() < lost_deadline) {
    server_->stream(qt::kLost, fuse_msgs::STATUS_LOST);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  const Result lost = client.newest();
  EXPECT_EQ(lost.error, Error::not_tracking);
  EXPECT_EQ(lost.estimate.t, qt::kLost);
  EXPECT_GT(count(), before);
}

TEST_F(QueryClient, LatestAsksForTheNewestEstimate) {
  Client client(options(kServerDomain));
  const Result r = client.latest();
  ASSERT_EQ(r.error, Error::ok) << r.message;
  EXPECT_EQ(r.estimate.status, Status::propagated);
  expect_known(r.estimate, qt::kLatest);
}

TEST_F(QueryClient, MapsEveryStatusAndOnlyATrackedPoseInTheHistoryIsOk) {
  Client client(options(kServerDomain));
  struct Case {
    double t;
    Status status;
    Error error;
  };
  const Case cases[] = {{qt::kCorrected, Status::interpolated, Error::ok},
                        {qt::kTooOld, Status::too_old, Error::out_of_range},
                        {qt::kInFuture, Status::in_future, Error::out_of_range},
                        {qt::kNotInitialised, Status::not_initialised, Error::not_ready},
                        {qt::kRelocalizing, Status::relocalizing, Error::not_tracking},
                        {qt::kLost, Status::lost, Error::not_tracking},
                        {150.0, Status::interpolated, Error::ok}};
  for (const Case& c : cases) {
    const Result r = client.at(c.t);
    EXPECT_EQ(r.error, c.error) << "t = " << c.t << ": " << to_string(r.error) << " " << r.message;
    EXPECT_EQ(r.ok(), c.error == Error::ok) << "t = " << c.t;
    if (!r.ok()) {
      EXPECT_FALSE(r.message.empty()) << "t = " << c.t << ": an error says why";
    }
    if (c.error == Error::not_ready) continue;
    EXPECT_EQ(r.estimate.status, c.status) << "t = " << c.t << ": " << to_string(r.estimate.status);
    EXPECT_EQ(r.estimate.t, c.t);
  }
}

TEST_F(QueryClient, ReturnsTheServersTypedErrors) {
  Client client(options(kServerDomain));
  Result r = client.at(qt::kNotReady);
  EXPECT_EQ(r.error, Error::not_ready);
  EXPECT_EQ(r.message, "IMU does not cover t yet");
  r = client.at(qt::kThrows);
  EXPECT_EQ(r.error, Error::internal);
  EXPECT_NE(r.message.find("boom in the handler"), std::string::npos) << r.message;
  r = client.at(qt::kServerRefuses);
  EXPECT_EQ(r.error, Error::bad_request);
  EXPECT_EQ(r.message, "refused by the server");
  EXPECT_FALSE(r.ok());
}

TEST_F(QueryClient, RejectsInvalidTimesWithoutSendingThem) {
  Client client(options(kServerDomain));
  ASSERT_TRUE(client.wait_for_server(10000));
  const double invalid[] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                            -std::numeric_limits<double>::infinity(), -1.0, -1e-9, 1e11, kMaxQueryTime * 2.0,
                            std::numeric_limits<double>::max()};
  for (const double t : invalid) {
    const auto start = std::chrono::steady_clock::now();
    const Result r = client.at(t);
    EXPECT_EQ(r.error, Error::bad_request) << "t = " << t;
    EXPECT_FALSE(r.message.empty());
    EXPECT_LT(test::seconds_since(start), 0.05) << "answered without a round trip";
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // a sent request would have arrived
  EXPECT_EQ(server_->invalid_requests(), 0) << "nothing was sent";
  EXPECT_EQ(client.at(kMaxQueryTime).error, Error::ok) << "the bound itself is accepted";
}

TEST_F(QueryClient, ConcurrentCallsEachGetTheirOwnReply) {
  Client client(options(kServerDomain));
  ASSERT_TRUE(client.wait_for_server(10000));
  std::atomic<int> wrong{0};
  std::vector<std::thread> threads;
  for (int k = 0; k < 4; ++k) {
    threads.emplace_back([&, k] {
      for (int i = 0; i < 10; ++i) {
        const double t = 1000.0 + 100 * k + i;
        const Result r = client.at(t);
        if (!r.ok() || r.estimate.t != t || r.estimate.position[0] != t + 1.0) ++wrong;
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(wrong, 0);
}

TEST_F(QueryClient, AMovedClientKeepsWorking) {
  Client first(options(kServerDomain));
  Client second = std::move(first);
  EXPECT_EQ(second.options().domain_id, kServerDomain);
  EXPECT_EQ(second.at(qt::kInterpolated).error, Error::ok);
}

TEST(QueryClientAlone, NoServerGivesUnavailableAtTheDeadline) {
  Client client(options(kEmptyDomain, 300));
  auto start = std::chrono::steady_clock::now();
  EXPECT_FALSE(client.wait_for_server(200));
  EXPECT_GE(test::seconds_since(start), 0.2);
  start = std::chrono::steady_clock::now();
  const Result r = client.at(10.0);
  const double elapsed = test::seconds_since(start);
  EXPECT_EQ(r.error, Error::unavailable);
  EXPECT_FALSE(r.message.empty());
  EXPECT_GE(elapsed, 0.3);
  EXPECT_LT(elapsed, 2.0);
  EXPECT_EQ(client.latest().error, Error::unavailable);
  EXPECT_EQ(client.at(std::nan("")).error, Error::bad_request) << "validation comes before the deadline";
}

TEST(QueryClientAlone, RefusesBadOptions) {
  auto make = [](auto change) {
    ClientOptions o = options(kEmptyDomain);
    change(o);
    Client c(o);
  };
  EXPECT_THROW(make([](ClientOptions& o) { o.vendor = "opendds"; }), std::invalid_argument);
  EXPECT_THROW(make([](ClientOptions& o) { o.domain_id = -1; }), std::invalid_argument);
  EXPECT_THROW(make([](ClientOptions& o) { o.domain_id = 102; }), std::invalid_argument);
  EXPECT_THROW(make([](ClientOptions& o) { o.deadline_ms = 0; }), std::invalid_argument);
  EXPECT_THROW(make([](ClientOptions& o) { o.max_participants = 2; }), std::invalid_argument);
  EXPECT_THROW(make([](ClientOptions& o) { o.socket_buffer_bytes = 1024; }), std::invalid_argument);
}

/// The thread ids of this process.
std::set<int> thread_ids() {
  std::set<int> ids;
  for (const auto& entry : std::filesystem::directory_iterator("/proc/self/task")) {
    ids.insert(std::stoi(entry.path().filename().string()));
  }
  return ids;
}

TEST(QueryClientAlone, ItsTransportThreadsRunWithTheRequestedSlice) {
  bool supported = false;
  std::thread([&] { supported = request_scheduler_slice(kMinSchedulerSliceUs).applied; }).join();
  if (!supported) GTEST_SKIP() << "no per-thread scheduler slices on this kernel (Linux 6.12+)";
  const int caller_slice = scheduler_slice_us();
  for (const int slice : {300, 0}) {
    const std::set<int> before = thread_ids();
    ClientOptions o = options(kEmptyDomain);
    o.scheduler_slice_us = slice;
    Client client(o);
    std::size_t new_threads = 0;
    for (const int tid : thread_ids()) {
      if (before.count(tid) != 0) continue;
      ++new_threads;
      if (slice > 0) {
        EXPECT_EQ(scheduler_slice_us(tid), slice) << "transport thread " << tid;
      } else {
        EXPECT_EQ(scheduler_slice_us(tid), caller_slice) << "transport thread " << tid << " keeps the default";
      }
    }
    EXPECT_GT(new_threads, 0u) << "the client's participant starts threads of its own";
    EXPECT_EQ(scheduler_slice_us(), caller_slice) << "the caller's thread is left as it was";
  }
  ClientOptions o = options(kEmptyDomain);
  for (const int bad : {-1, 50, 100001}) {
    o.scheduler_slice_us = bad;
    EXPECT_THROW(Client{o}, std::invalid_argument) << bad;
  }
}

TEST(QueryClientAlone, NamesErrorsAndStatuses) {
  EXPECT_STREQ(to_string(Error::ok), "ok");
  EXPECT_STREQ(to_string(Error::out_of_range), "out_of_range");
  EXPECT_STREQ(to_string(Error::not_tracking), "not_tracking");
  EXPECT_STREQ(to_string(Error::bad_request), "bad_request");
  EXPECT_STREQ(to_string(Error::not_ready), "not_ready");
  EXPECT_STREQ(to_string(Error::unavailable), "unavailable");
  EXPECT_STREQ(to_string(Error::internal), "internal");
  EXPECT_STREQ(to_string(Status::interpolated), "interpolated");
  EXPECT_STREQ(to_string(Status::propagated), "propagated");
  EXPECT_STREQ(to_string(Status::too_old), "too_old");
  EXPECT_STREQ(to_string(Status::in_future), "in_future");
  EXPECT_STREQ(to_string(Status::not_initialised), "not_initialised");
  EXPECT_STREQ(to_string(Status::relocalizing), "relocalizing");
  EXPECT_STREQ(to_string(Status::lost), "lost");
}

/// The client on Cyclone DDS against the Fast DDS server (skipped while that backend is absent).
TEST(QueryClientCrossVendor, CycloneClientAsksAFastDdsServer) {
  constexpr int kDomain = 46;
  test::FakeQueryServer server(kDomain);
  ClientOptions o = options(kDomain);
  o.vendor = "cyclonedds";
  std::unique_ptr<Client> client;
  try {
    client = std::make_unique<Client>(o);
  } catch (const std::runtime_error& e) {
    GTEST_SKIP() << "Cyclone DDS backend unavailable: " << e.what();
  }
  ASSERT_TRUE(client->wait_for_server(10000));
  const Result r = client->at(qt::kInterpolated);
  ASSERT_EQ(r.error, Error::ok) << r.message;
  expect_known(r.estimate, qt::kInterpolated);
}

}  // namespace
}  // namespace fuse::query

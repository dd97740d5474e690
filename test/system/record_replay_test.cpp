// fuse-record (issue 5 item 2) as a real process on loopback:
//   - a lockstep pipeline (fuse-launch) recorded by fuse-record and the recording replayed by a
//     second lockstep pipeline give the same trajectory (largest position difference ≤ 1 mm,
//     expected 0); the recording holds every IMU sample and scan of the original;
//   - rotation by size and by duration gives several complete files whose message counts add
//     up to what was published, with nothing lost or repeated at the file boundaries;
//   - SIGINT (and SIGTERM) in the middle of a recording leave a complete, verifiable file;
//   - a queue too small for the samples drops them, and the drops are counted in the summary;
//   - bad arguments stop it with exit code 2.
// The files these tests leave are opened with @mcap/core by the ctest system.record.mcap_core
// (read_recording.mjs of test/io/interop). DDS domains 100 and 101 belong to this file.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "fuse/eval/trajectory.hpp"
#include "fuse/io/mcap_reader.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/launch/process.hpp"
#include "fuse/transport/msg_traits.hpp"
#include "fuse/transport/qos.hpp"

namespace fuse {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using launch::Process;

constexpr int kDomainRecord = 100;  ///< the recorded pipeline and the recorder-only tests
constexpr int kDomainReplay = 101;  ///< the pipeline replaying the recording
const std::string kData = std::string(FUSE_TEST_DATA) + "/corridor10_record";
const std::string kConfig = std::string(FUSE_CONFIG_DIR) + "/mid360.yaml";
const std::string kBin = FUSE_BIN_DIR;
const std::string kOut = FUSE_TEST_OUT;

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

bool wait_for_text(const std::string& path, const std::string& text, std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (read_text(path).find(text) != std::string::npos) return true;
    std::this_thread::sleep_for(50ms);
  }
  return false;
}

/// Largest position difference between two trajectories at their common timestamps.
double max_difference(const std::vector<StampedPose>& a, const std::vector<StampedPose>& b, std::size_t* common) {
  std::map<long long, Eigen::Vector3d> by_time;
  for (const auto& p : a) by_time[std::llround(p.t * 1e6)] = p.p;
  double worst = 0.0;
  *common = 0;
  for (const auto& p : b) {
    auto it = by_time.find(std::llround(p.t * 1e6));
    if (it == by_time.end()) continue;
    ++*common;
    worst = std::max(worst, (it->second - p.p).norm());
  }
  return worst;
}

/// What the recorder printed: per topic written/dropped/malformed, per file message counts.
struct Summary {
  struct Topic {
    std::uint64_t messages = 0, bytes = 0, dropped = 0, malformed = 0;
  };
  std::map<std::string, Topic> topics;
  std::map<std::string, std::uint64_t> files;  ///< path -> messages
  std::uint64_t total = 0, dropped = 0;
  bool found = false;
};

Summary parse_summary(const std::string& log) {
  Summary s;
  const std::regex topic(R"(topic (\S+): (\d+) messages, (\d+) bytes, (\d+) dropped, (\d+) malformed)");
  const std::regex file(R"(file (\S+): (\d+) messages)");
  const std::regex total(R"(total: (\d+) messages, \d+ bytes, (\d+) dropped)");
  std::istringstream in(log);
  for (std::string line; std::getline(in, line);) {
    std::smatch m;
    if (std::regex_search(line, m, topic)) {
      s.topics[m[1]] = {std::stoull(m[2]), std::stoull(m[3]), std::stoull(m[4]), std::stoull(m[5])};
    } else if (std::regex_search(line, m, file)) {
      s.files[m[1]] = std::stoull(m[2]);
    } else if (std::regex_search(line, m, total)) {
      s.total = std::stoull(m[1]);
      s.dropped = std::stoull(m[2]);
      s.found = true;
    }
  }
  return s;
}

/// Messages per topic of one MCAP file, after the reader's full check (every record and CRC,
/// the Statistics counts). Fails the test when the file is incomplete.
std::map<std::string, std::uint64_t> verified_counts(const std::string& path, std::vector<double>* imu_times = nullptr) {
  std::map<std::string, std::uint64_t> counts;
  io::McapReader reader(path);
  EXPECT_FALSE(reader.salvage_mode()) << path << ": " << reader.salvage_error();
  EXPECT_TRUE(reader.has_summary()) << path;
  EXPECT_NO_THROW(reader.verify()) << path;
  reader.start();
  io::McapMessage m;
  while (reader.next(m)) {
    ++counts[m.channel->topic];
    if (imu_times && m.channel->topic == transport::topics::kImu) {
      fuse_msgs::ImuSample s;
      EXPECT_TRUE(transport::deserialize(m.data.data(), m.data.size(), s));
      imu_times->push_back(s.t());
    }
  }
  return counts;
}

/// Every message's log time against the span of the IMU samples' own times (ns): the recording's
/// one time base is the sensor clock, so health and status sent before the data are logged
/// within the run too, never at 0 (1970).
void expect_log_times_within_the_run(const std::string& path) {
  io::McapReader reader(path);
  reader.start();
  io::McapMessage m;
  std::uint64_t first_log = ~0ull, last_log = 0, first_imu = ~0ull, last_imu = 0;
  std::string first_topic;
  while (reader.next(m)) {
    if (m.header.log_time < first_log) first_topic = m.channel->topic;
    first_log = std::min(first_log, m.header.log_time);
    last_log = std::max(last_log, m.header.log_time);
    if (m.channel->topic == transport::topics::kImu) {
      first_imu = std::min(first_imu, m.header.log_time);
      last_imu = std::max(last_imu, m.header.log_time);
    }
  }
  constexpr std::uint64_t kSlackNs = 60'000'000'000ull;  // start-up before the data, shut-down after it
  ASSERT_LE(first_imu, last_imu) << path << ": no IMU samples";
  EXPECT_GE(first_log + kSlackNs, first_imu) << path << ": '" << first_topic << "' logged at " << first_log << " ns";
  EXPECT_LE(last_log, last_imu + kSlackNs) << path;
}

/// The recording's files in name order (PREFIX_000.mcap, PREFIX_001.mcap, ...).
std::vector<std::string> mcap_files(const std::string& dir) {
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() == ".mcap") files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

/// fuse-record as a child process on `domain`, writing into kOut/name.
class RecorderProcess {
 public:
  RecorderProcess(const std::string& name, int domain, const std::vector<std::string>& extra)
      : dir_(kOut + "/" + name), log_(kOut + "/" + name + ".log") {
    fs::remove_all(dir_);
    fs::remove(log_);
    fs::create_directories(fs::path(log_).parent_path());
    std::vector<std::string> argv{kBin + "/fuse-record", "--config", kConfig, "--set",
                                  "transport.domain_id=" + std::to_string(domain), "--out", dir_};
    argv.insert(argv.end(), extra.begin(), extra.end());
    proc_.emplace(Process::spawn(argv, log_));
  }
  bool wait_ready() { return wait_for_text(log_, "recording ", 30s); }
  /// Sends `sig` and waits for the exit; its exit code (-1 when killed or hung).
  int stop(int sig = SIGINT) {
    proc_->signal(sig);
    const auto status = proc_->wait_for(60s);
    return status && !status->signaled ? status->code : -1;
  }
  /// Waits for it to exit by itself; its exit code (-1 when killed, or still running at the timeout).
  int wait_exit(std::chrono::seconds timeout) {
    const auto status = proc_->wait_for(timeout);
    return status && !status->signaled ? status->code : -1;
  }
  Summary summary() const { return parse_summary(read_text(log_)); }
  std::string log() const { return read_text(log_); }
  const std::string& dir() const { return dir_; }

 private:
  std::string dir_, log_;
  std::optional<Process> proc_;
};

/// Runs fuse-launch lockstep on `input`; its exit code.
/// extra_readers: readers of the IMU and scan topics besides the pipeline's (a recorder) that the
/// replay waits for, so that they get every sample.
int lockstep(const std::string& input, const std::string& out, int domain, int extra_readers = 0) {
  fs::remove_all(out);
  fs::create_directories(out);
  auto p = Process::spawn({kBin + "/fuse-launch", "--config", kConfig, "--input", input, "--mode", "lockstep", "--out", out,
                           "--domain", std::to_string(domain), "--bin-dir", kBin, "--set",
                           "ingest.extra_readers=" + std::to_string(extra_readers)},
                          out + "/fuse-launch.log");
  const auto status = p.wait_for(600s);
  return status && !status->signaled ? status->code : -1;
}

/// IMU and scan events in a recording, as fuse-ingest reads them.
std::pair<std::size_t, std::size_t> event_counts(const std::string& input) {
  auto source = io::open_sensor_source(input);
  io::SensorEvent ev;
  std::size_t imu = 0, scans = 0;
  while (source->next(ev)) (ev.kind == io::SensorEvent::Kind::kImu ? imu : scans)++;
  return {imu, scans};
}

/// A test-side publisher of IMU samples and scans on `domain`.
class SensorPublisher {
 public:
  explicit SensorPublisher(int domain) {
    transport::TransportConfig tc;
    tc.domain_id = domain;
    participant_ = transport::make_participant(tc, "test-record-publisher");
    imu_ = std::make_unique<transport::Publisher<fuse_msgs::ImuSample>>(*participant_, transport::topics::kImu);
    scan_ = std::make_unique<transport::Publisher<fuse_msgs::LidarScan>>(*participant_, transport::topics::kLidarScan);
  }
  bool wait_matched(std::chrono::seconds timeout) {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      if (imu_->matched() > 0 && scan_->matched() > 0) return true;
      std::this_thread::sleep_for(20ms);
    }
    return false;
  }
  void imu(double t) {
    fuse_msgs::ImuSample s;
    s.t(t);
    s.gyro().x(0.01);
    s.accel().z(9.81);
    s.sequence_number(++imu_seq_);
    s.frame("imu");
    ASSERT_TRUE(imu_->publish(s));
  }
  void scan(double t_end, std::size_t points) {
    constexpr double kScanPeriod = 0.1;
    fuse_msgs::LidarScan s;
    s.start_time(t_end - kScanPeriod);
    s.end_time(t_end);
    s.sequence_number(++scan_seq_);
    s.frame("lidar");
    s.points().resize(points);
    for (std::size_t i = 0; i < points; ++i) {
      auto& p = s.points()[i];
      p.x(1.0f + static_cast<float>(i) * 1e-3f);
      p.y(2.0f);
      p.z(0.5f);
      p.intensity(10.0f);
      p.time_offset(static_cast<float>(kScanPeriod * static_cast<double>(i) / static_cast<double>(points)));
      p.ring(static_cast<std::uint16_t>(i % 4));
    }
    ASSERT_TRUE(scan_->publish(s));
  }

 private:
  std::unique_ptr<transport::Participant> participant_;
  std::unique_ptr<transport::Publisher<fuse_msgs::ImuSample>> imu_;
  std::unique_ptr<transport::Publisher<fuse_msgs::LidarScan>> scan_;
  std::uint64_t imu_seq_ = 0, scan_seq_ = 0;
};

/// How long reliable delivery to the recorder is given after the last publication.
constexpr auto kDeliveryGrace = 2s;

TEST(RecordReplay, RecordedLockstepPipelineReplaysToTheSameTrajectory) {
  ASSERT_TRUE(fs::exists(kData + "/recording.mcap")) << "fixture missing: " << kData;
  RecorderProcess recorder("record_replay/recorded", kDomainRecord,
                           {"--calibration-from", kData + "/recording.mcap"});
  ASSERT_TRUE(recorder.wait_ready()) << recorder.log();

  const std::string first = kOut + "/record_replay/first", second = kOut + "/record_replay/second";
  ASSERT_EQ(lockstep(kData + "/recording.mcap", first, kDomainRecord, 1), 0) << read_text(first + "/fuse-launch.log");
  std::this_thread::sleep_for(kDeliveryGrace);
  ASSERT_EQ(recorder.stop(SIGINT), 0) << recorder.log();
  const Summary summary = recorder.summary();
  ASSERT_TRUE(summary.found) << recorder.log();
  EXPECT_EQ(summary.dropped, 0u);

  // The recording holds every IMU sample and scan of the original, as fuse-ingest reads them.
  const auto files = mcap_files(recorder.dir());
  ASSERT_EQ(files.size(), 1u);
  const auto original = event_counts(kData + "/recording.mcap");
  const auto recorded = event_counts(files[0]);
  EXPECT_EQ(recorded.first, original.first) << "IMU samples";
  EXPECT_EQ(recorded.second, original.second) << "scans";
  const auto counts = verified_counts(files[0]);
  EXPECT_GT(counts.count(transport::topics::kCorrection), 0u) << "the pipeline's own topics are recorded too";
  EXPECT_GT(counts.count(transport::topics::kHealth), 0u);
  expect_log_times_within_the_run(files[0]);
  EXPECT_EQ(summary.topics.at("imu").messages, original.first);
  EXPECT_EQ(summary.topics.at("lidar/scan").messages, original.second);

  ASSERT_EQ(lockstep(files[0], second, kDomainReplay), 0) << read_text(second + "/fuse-launch.log");
  const auto a = eval::read_tum(first + "/trajectory.tum");
  const auto b = eval::read_tum(second + "/trajectory.tum");
  ASSERT_GT(a.size(), 10u);
  std::size_t common = 0;
  const double worst = max_difference(a, b, &common);
  EXPECT_EQ(b.size(), a.size());
  EXPECT_EQ(common, a.size());
  EXPECT_LE(worst, 1e-3) << "largest position difference between the original and the replayed run";
  RecordProperty("max_difference_m", std::to_string(worst));
  RecordProperty("poses", std::to_string(a.size()));
  std::cout << "record/replay: " << a.size() << " poses, largest position difference " << worst << " m; recorded "
            << summary.total << " messages (" << recorded.first << " IMU, " << recorded.second << " scans)\n";
}

/// Publishes `imu_count` IMU samples at 200 Hz sensor time with a scan every 20th, paced by `pause`.
void publish_sequence(SensorPublisher& pub, int imu_count, std::size_t scan_points, std::chrono::milliseconds pause) {
  constexpr double kImuPeriod = 0.005;
  constexpr int kImuPerScan = 20;
  for (int i = 1; i <= imu_count; ++i) {
    pub.imu(i * kImuPeriod);
    if (i % kImuPerScan == 0) pub.scan(i * kImuPeriod, scan_points);
    if (pause.count() > 0) std::this_thread::sleep_for(pause);
  }
}

/// Every file complete, counts add up to what was published, IMU times strictly increasing
/// across the files (nothing lost or repeated at a boundary).
void check_rotated(const RecorderProcess& recorder, std::size_t min_files, std::uint64_t imu, std::uint64_t scans) {
  const Summary summary = recorder.summary();
  ASSERT_TRUE(summary.found) << recorder.log();
  const auto files = mcap_files(recorder.dir());
  EXPECT_GE(files.size(), min_files);
  EXPECT_EQ(summary.files.size(), files.size());
  std::uint64_t total_imu = 0, total_scans = 0;
  std::vector<double> times;
  for (const auto& f : files) {
    const auto counts = verified_counts(f, &times);
    const std::uint64_t n = (counts.count("imu") ? counts.at("imu") : 0) + (counts.count("lidar/scan") ? counts.at("lidar/scan") : 0);
    EXPECT_EQ(summary.files.count(f) ? summary.files.at(f) : ~0ull, n) << f;
    total_imu += counts.count("imu") ? counts.at("imu") : 0;
    total_scans += counts.count("lidar/scan") ? counts.at("lidar/scan") : 0;
  }
  EXPECT_EQ(total_imu, imu);
  EXPECT_EQ(total_scans, scans);
  EXPECT_EQ(summary.total, imu + scans);
  for (std::size_t i = 1; i < times.size(); ++i) ASSERT_LT(times[i - 1], times[i]) << "IMU sample " << i;
}

TEST(RecordReplay, RotationBySizeGivesCompleteFilesWhoseCountsAddUp) {
  constexpr std::uint64_t kMaxBytes = 200'000;
  RecorderProcess recorder("record_rotation_size", kDomainRecord,
                           {"--include", "imu,lidar/scan", "--max-bytes", std::to_string(kMaxBytes)});
  ASSERT_TRUE(recorder.wait_ready()) << recorder.log();
  SensorPublisher pub(kDomainRecord);
  ASSERT_TRUE(pub.wait_matched(20s));
  constexpr int kImu = 400;
  constexpr std::size_t kPoints = 2000;  // ~48 kB a scan: 20 scans make ~1 MB, 5+ files
  publish_sequence(pub, kImu, kPoints, 1ms);
  std::this_thread::sleep_for(kDeliveryGrace);
  ASSERT_EQ(recorder.stop(SIGTERM), 0) << recorder.log();
  check_rotated(recorder, 4, kImu, kImu / 20);
}

TEST(RecordReplay, RotationByDurationGivesCompleteFilesWhoseCountsAddUp) {
  RecorderProcess recorder("record_rotation_time", kDomainRecord, {"--include", "imu,lidar/scan", "--max-seconds", "0.5"});
  ASSERT_TRUE(recorder.wait_ready()) << recorder.log();
  SensorPublisher pub(kDomainRecord);
  ASSERT_TRUE(pub.wait_matched(20s));
  constexpr int kImu = 400;  // 2 s at 5 ms
  publish_sequence(pub, kImu, 100, 5ms);
  std::this_thread::sleep_for(kDeliveryGrace);
  ASSERT_EQ(recorder.stop(SIGINT), 0) << recorder.log();
  check_rotated(recorder, 3, kImu, kImu / 20);
}

TEST(RecordReplay, SigintWhilePublishingLeavesACompleteFile) {
  RecorderProcess recorder("record_sigint", kDomainRecord, {"--include", "imu,lidar/scan"});
  ASSERT_TRUE(recorder.wait_ready()) << recorder.log();
  SensorPublisher pub(kDomainRecord);
  ASSERT_TRUE(pub.wait_matched(20s));
  std::atomic<bool> done{false};
  std::thread publisher([&] {
    for (int i = 1; !done && i < 100000; ++i) {
      pub.imu(i * 0.005);
      if (i % 20 == 0) pub.scan(i * 0.005, 500);
      std::this_thread::sleep_for(1ms);
    }
  });
  std::this_thread::sleep_for(1500ms);
  const int code = recorder.stop(SIGINT);  // while samples still arrive
  done = true;
  publisher.join();
  ASSERT_EQ(code, 0) << recorder.log();
  const Summary summary = recorder.summary();
  ASSERT_TRUE(summary.found) << recorder.log();
  const auto files = mcap_files(recorder.dir());
  ASSERT_EQ(files.size(), 1u);
  const auto counts = verified_counts(files[0]);
  const std::uint64_t n = counts.at("imu") + (counts.count("lidar/scan") ? counts.at("lidar/scan") : 0);
  EXPECT_GT(counts.at("imu"), 100u);
  EXPECT_EQ(n, summary.total);
}

TEST(RecordReplay, FullQueueDropsAreCountedNotSilent) {
  // A queue smaller than one scan: every scan is refused and counted; IMU samples still fit.
  RecorderProcess recorder("record_overflow", kDomainRecord, {"--include", "imu,lidar/scan", "--queue-bytes", "4096"});
  ASSERT_TRUE(recorder.wait_ready()) << recorder.log();
  SensorPublisher pub(kDomainRecord);
  ASSERT_TRUE(pub.wait_matched(20s));
  publish_sequence(pub, 200, 2000, 2ms);
  std::this_thread::sleep_for(kDeliveryGrace);
  ASSERT_EQ(recorder.stop(SIGINT), 0) << recorder.log();
  const Summary summary = recorder.summary();
  ASSERT_TRUE(summary.found) << recorder.log();
  EXPECT_EQ(summary.topics.at("lidar/scan").dropped, 10u);
  EXPECT_EQ(summary.topics.at("lidar/scan").messages, 0u);
  EXPECT_EQ(summary.topics.at("imu").messages + summary.topics.at("imu").dropped, 200u);
  EXPECT_NE(recorder.log().find("queue full"), std::string::npos) << "drops are logged";
}

TEST(RecordReplay, BadArgumentsStopWithAMessage) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--include", "no/such/topic"}, "leave no topic"},
      {{"--max-bytes", "lots"}, "--max-bytes"},
      {{"--max-seconds", "-1"}, "--max-seconds"},
      {{"--compression", "gzip"}, "--compression"},
      {{"--queue-bytes", "10"}, "--queue-bytes"},
      {{"--include", "imu,,health"}, "empty item"},
      {{"--calibration-from", "/nonexistent/recording.mcap"}, "no such file"},
      {{"--frobnicate", "1"}, "--frobnicate"},
  };
  int n = 0;
  for (const auto& [args, message] : cases) {
    RecorderProcess recorder("record_bad_" + std::to_string(n++), kDomainRecord, args);
    // It stops by itself (after the message it still closes its DDS participant).
    EXPECT_EQ(recorder.wait_exit(20s), 2) << args[0] << ": " << recorder.log();
    EXPECT_NE(recorder.log().find(message), std::string::npos) << args[0] << ": " << recorder.log();
  }
}

}  // namespace
}  // namespace fuse

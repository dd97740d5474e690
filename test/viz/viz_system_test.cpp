// The live view end to end: the four services replay a simulated recording in lockstep beside
// fuse-viz, and a Foxglove client written with Foxglove's own client library (client/, Node.js:
// @foxglove/ws-protocol and ws) subscribes to every channel and decodes each message with the
// schema its channel advertises. Checked on content, not only on decoding:
//   - each scan-rate pose equals what fuse-query answers for the same time;
//   - each scan's points are the deskewed scan fuse-update published (update/world_scan, read
//     here over DDS): same count, same coordinates (sums);
//   - the last map's point count equals the map server's (map/status, what fuse-map-ctl stats
//     says);
//   - every frame_id is reachable in the one transform tree (world -> imu -> lidar).
// fuse-record records the same run; its file's Foxglove channels are read back with the reference
// MCAP reader and the schemas embedded in the file (client/read_foxglove_recording.mjs): a
// /fuse/scan per update/world_scan sample, and a last /fuse/map of the map server's size.
// DDS domain 9 belongs to this file.
#include <gtest/gtest.h>
#include <json/json.h>
#include <sys/resource.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <regex>
#include <sstream>
#include <thread>

#include "fuse/launch/process.hpp"
#include "system_test_util.hpp"
#include "fuse/transport/msg_traits.hpp"
#include "fuse/transport/transport.hpp"

namespace fuse {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using launch::Process;
using namespace viz_test;

constexpr int kDomain = 9;
const std::string kClientDir = FUSE_VIZ_CLIENT_DIR;

/// The client's output: message lines (a "topic"), or protocol lines (a "kind": serverInfo,
/// channel, error, summary).
std::vector<Json::Value> json_lines(const std::string& path) {
  std::vector<Json::Value> out;
  std::stringstream in(read_file(path));
  const std::unique_ptr<Json::CharReader> reader(Json::CharReaderBuilder().newCharReader());
  for (std::string line; std::getline(in, line);) {
    Json::Value v;
    std::string errors;
    if (!line.empty() && reader->parse(line.data(), line.data() + line.size(), &v, &errors)) out.push_back(v);
  }
  return out;
}

/// What the test itself reads over DDS: the deskewed scans and the map server's point count.
struct DdsSide {
  struct Scan {
    std::size_t points = 0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  };
  std::mutex mutex;
  std::map<long long, Scan> scans;  // by scan end time in microseconds
  std::uint64_t map_points = 0;
  std::unique_ptr<transport::Participant> participant;
  std::unique_ptr<transport::Subscriber<fuse_msgs::WorldScan>> world_scans;
  std::unique_ptr<transport::Subscriber<fuse_msgs::MapStatus>> status;

  DdsSide() {
    transport::TransportConfig config;
    config.domain_id = kDomain;
    participant = transport::make_participant(config, "viz-test");
    world_scans = std::make_unique<transport::Subscriber<fuse_msgs::WorldScan>>(
        *participant, transport::topics::kWorldScan, [this](const fuse_msgs::WorldScan& s) {
          Scan scan;
          scan.points = s.points().size();
          for (const auto& p : s.points()) scan.sum += Eigen::Vector3d(p.x(), p.y(), p.z());
          std::lock_guard<std::mutex> lock(mutex);
          scans[std::llround(s.t() * 1e6)] = scan;
        });
    status = std::make_unique<transport::Subscriber<fuse_msgs::MapStatus>>(
        *participant, transport::topics::kMapStatus, [this](const fuse_msgs::MapStatus& s) {
          std::lock_guard<std::mutex> lock(mutex);
          map_points = s.points();
        });
  }
};

double seconds(const Json::Value& line) { return line["t"].asDouble(); }

TEST(VizSystem, AFoxgloveClientSeesWhatTheSystemEstimates) {
  if (!fs::exists(kRecording)) GTEST_SKIP() << "no recording at " << kRecording << " (the fuse_sim_data fixture)";
  ASSERT_TRUE(fs::exists(kClientDir + "/node_modules/@foxglove/ws-protocol")) << "npm install did not run in " << kClientDir;
  const std::string dir = kOut + "/end_to_end";
  fs::remove_all(dir);
  fs::create_directories(dir + "/logs");
  auto args = [](const std::string& service, const std::vector<std::string>& more) {
    return service_argv(service, kDomain, {"ingest.lockstep_timeout_s=1.5", "update.map_sync_timeout_s=3"}, more);
  };
  DdsSide dds;
  std::map<std::string, Process> services;
  services.emplace("fuse-map", Process::spawn(args("fuse-map", {"--map-dir", dir + "/map"}), dir + "/logs/fuse-map.log"));
  services.emplace("fuse-state", Process::spawn(args("fuse-state", {"--trajectory", dir + "/trajectory.tum",
                                                                    "--calibration-from", kRecording}),
                                                dir + "/logs/fuse-state.log"));
  services.emplace("fuse-update", Process::spawn(args("fuse-update", {}), dir + "/logs/fuse-update.log"));
  services.emplace("fuse-viz", Process::spawn(args("fuse-viz", {"--set", "viz.port=0", "--set", "viz.map_period_s=0.2",
                                                                "--set", "viz.trajectory_period_s=0.2"}),
                                              dir + "/logs/fuse-viz.log"));
  // fuse-viz took a free port and says which.
  std::smatch match;
  const std::regex serving(R"(on ws://127\.0\.0\.1:([0-9]+))");
  std::string viz_log;
  ASSERT_TRUE(wait_until([&] {
    viz_log = read_file(dir + "/logs/fuse-viz.log");
    return std::regex_search(viz_log, match, serving);
  }, 60s)) << viz_log;
  const std::string url = "ws://127.0.0.1:" + match[1].str();

  const std::string lines_path = dir + "/client.jsonl";
  Process client = Process::spawn({FUSE_NODE, kClientDir + "/viz_client.mjs", url, lines_path}, dir + "/logs/client.log");
  const auto count = [&](const std::string& kind) {
    std::size_t n = 0;
    for (const Json::Value& v : json_lines(lines_path)) n += v["kind"].asString() == kind;
    return n;
  };
  ASSERT_TRUE(wait_until([&] { return count("channel") == 8; }, 60s)) << read_file(dir + "/logs/client.log");
  // fuse-viz reads the IMU-rate odometry only while a client wants /fuse/pose or /tf, and the
  // world scan only while one wants /fuse/scan.
  EXPECT_EQ(viz_log.find("reading state/odometry"), std::string::npos) << "read before any client wanted it";
  EXPECT_EQ(viz_log.find("reading update/world_scan"), std::string::npos) << "read before any client wanted it";
  ASSERT_TRUE(wait_until([&] {
    const std::string log = read_file(dir + "/logs/fuse-viz.log");
    return log.find("a client wants /fuse/pose or /tf: reading state/odometry") != std::string::npos &&
           log.find("a client wants /fuse/scan: reading update/world_scan") != std::string::npos;
  }, 60s)) << read_file(dir + "/logs/fuse-viz.log");
  // Every thread of fuse-viz (its own, the DDS library's, the server's, the signal thread made at
  // start-up) runs at niceness viz.nice (10 by default): the viewer yields the CPU to the estimator.
  std::size_t threads = 0;
  for (const auto& task : fs::directory_iterator("/proc/" + std::to_string(services.at("fuse-viz").pid()) + "/task")) {
    const auto tid = static_cast<id_t>(std::stoul(task.path().filename().string()));
    errno = 0;
    const int nice = ::getpriority(PRIO_PROCESS, tid);
    if (errno != 0) continue;  // the thread ended meanwhile
    ++threads;
    EXPECT_EQ(nice, 10) << "fuse-viz thread " << tid;
  }
  EXPECT_GE(threads, 3u) << "fuse-viz's threads were not found";

  Process recorder = Process::spawn(args("fuse-record", {"--out", dir + "/recording", "--calibration-from", kRecording}),
                                    dir + "/logs/fuse-record.log");
  ASSERT_TRUE(wait_until([&] { return read_file(dir + "/logs/fuse-record.log").find("recording ") != std::string::npos; },
                         60s));
  Process ingest = Process::spawn(args("fuse-ingest", {"--input", kRecording, "--mode", "lockstep"}),
                                  dir + "/logs/fuse-ingest.log");
  const auto done = ingest.wait_for(240s);
  ASSERT_TRUE(done.has_value()) << "replay did not finish";
  EXPECT_EQ(done->code, 0);

  // The last map the client got has as many points as the map server holds.
  std::uint64_t server_points = 0;
  double last_map_points = -1;
  ASSERT_TRUE(wait_until([&] {
    {
      std::lock_guard<std::mutex> lock(dds.mutex);
      server_points = dds.map_points;
    }
    for (const Json::Value& v : json_lines(lines_path)) {
      if (!v.isMember("kind") && v["topic"].asString() == "/fuse/map") last_map_points = v["points"].asDouble();
    }
    return server_points > 0 && last_map_points == static_cast<double>(server_points);
  }, 60s)) << "map server " << server_points << " points, client's last map " << last_map_points;

  // The recording of the same run draws the same: read back with the schemas in the file.
  const auto recorded = recorder.terminate(30s);
  EXPECT_EQ(recorded.status.code, 0) << read_file(dir + "/logs/fuse-record.log");
  Process reader = Process::spawn({FUSE_NODE, kClientDir + "/read_foxglove_recording.mjs",
                                   dir + "/recording/recording_000.mcap", "--pair", "/fuse/scan=update/world_scan",
                                   "--pair", "/fuse/pose=state/odometry", "--map-points", std::to_string(server_points)},
                                  dir + "/logs/read_recording.log");
  const auto read_status = reader.wait_for(120s);
  ASSERT_TRUE(read_status.has_value());
  EXPECT_EQ(read_status->code, 0) << read_file(dir + "/logs/read_recording.log");

  // Scan-rate poses against fuse-query for the same time.
  std::vector<Json::Value> poses;
  for (const Json::Value& v : json_lines(lines_path)) {
    if (!v.isMember("kind") && v["topic"].asString() == "/fuse/pose_scan") poses.push_back(v);
  }
  ASSERT_GT(poses.size(), 100u);
  int compared = 0;
  for (std::size_t i = poses.size() / 10; i < poses.size(); i += poses.size() / 10) {
    const Json::Value& pose = poses[i];
    Process query = Process::spawn({kBin + "/fuse-query", "--domain", std::to_string(kDomain), "--json", "--time",
                                    std::to_string(seconds(pose)), "--deadline-ms", "20000"},
                                   dir + "/logs/query-" + std::to_string(i) + ".log");
    const auto status = query.wait_for(60s);
    ASSERT_TRUE(status.has_value());
    const std::string text = read_file(dir + "/logs/query-" + std::to_string(i) + ".log");
    const auto at = text.find('{');
    ASSERT_NE(at, std::string::npos) << text;
    Json::Value reply;
    std::string errors;
    const std::unique_ptr<Json::CharReader> reader(Json::CharReaderBuilder().newCharReader());
    ASSERT_TRUE(reader->parse(text.data() + at, text.data() + text.size(), &reply, &errors)) << text;
    for (int k = 0; k < 3; ++k) {
      const char* axis = k == 0 ? "x" : k == 1 ? "y" : "z";
      EXPECT_NEAR(reply["position"][k].asDouble(), pose["position"][axis].asDouble(), 1e-4)
          << "at t=" << seconds(pose) << ": " << text;
    }
    ++compared;
  }
  EXPECT_GE(compared, 9);

  // Scans: the client's points are the deskewed scan fuse-update published.
  int matched = 0;
  for (const Json::Value& v : json_lines(lines_path)) {
    if (v.isMember("kind") || v["topic"].asString() != "/fuse/scan") continue;
    EXPECT_EQ(v["frame_id"].asString(), "world");
    std::lock_guard<std::mutex> lock(dds.mutex);
    const auto it = dds.scans.find(std::llround(seconds(v) * 1e6));
    if (it == dds.scans.end()) continue;  // best-effort: either side may have missed one
    ++matched;
    EXPECT_EQ(v["points"].asUInt64(), it->second.points);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(v["sum"][k].asDouble(), it->second.sum[k], 1e-3 * std::max(1.0, std::abs(it->second.sum[k])));
    }
  }
  EXPECT_GT(matched, 100) << "scans seen by both the client and the test";

  // Every frame reachable; every channel decoded; nothing failed.
  ASSERT_TRUE(client.signal(SIGTERM));
  const auto client_status = client.wait_for(30s);
  ASSERT_TRUE(client_status.has_value());
  EXPECT_EQ(client_status->code, 0) << read_file(dir + "/logs/client.log");
  EXPECT_TRUE(wait_until([&] {
    return read_file(dir + "/logs/fuse-viz.log").find("stopped reading state/odometry") != std::string::npos;
  }, 60s)) << "the odometry reader outlived its last client";
  EXPECT_TRUE(wait_until([&] {
    return read_file(dir + "/logs/fuse-viz.log").find("stopped reading update/world_scan") != std::string::npos;
  }, 60s)) << "the world scan reader outlived its last client";
  const std::vector<Json::Value> all = json_lines(lines_path);
  ASSERT_FALSE(all.empty());
  const Json::Value& summary = all.back();
  ASSERT_EQ(summary["kind"].asString(), "summary") << read_file(dir + "/logs/client.log");
  EXPECT_EQ(summary["errors"].asInt(), 0);
  ASSERT_EQ(summary["roots"].size(), 1u);
  EXPECT_EQ(summary["roots"][0].asString(), "world");
  EXPECT_EQ(summary["unreachable"].size(), 0u);
  std::set<std::string> frames;
  for (const Json::Value& f : summary["frames"]) frames.insert(f.asString());
  EXPECT_EQ(frames, (std::set<std::string>{"world", "imu", "lidar"}));
  for (const char* topic : {"/fuse/pose", "/fuse/pose_scan", "/tf", "/tf_static", "/fuse/scan", "/fuse/map",
                            "/fuse/trajectory", "/fuse/health"}) {
    EXPECT_GT(summary["counts"][topic].asUInt64(), 0u) << topic << " never arrived";
  }
  for (auto& [name, process] : services) {
    const auto t = process.terminate(10s);
    EXPECT_FALSE(t.escalated) << name;
    EXPECT_EQ(t.status.code, 0) << name << ": " << read_file(dir + "/logs/" + name + ".log").substr(0, 2000);
  }
}

}  // namespace
}  // namespace fuse

// fuse-record: records FUSE DDS topics into the project's MCAP recording format (issue 5 item 2).
//
//   fuse-record --config FILE [--set key=value]... [--out DIR] [--prefix NAME]
//               [--include PATTERNS] [--exclude PATTERNS]     (comma-separated globs; all topics by default)
//               [--max-bytes N] [--max-seconds S] [--queue-bytes N]
//               [--compression zstd|lz4|none] [--calibration-from INPUT] [--foxglove on|off]
//
// Writes DIR/NAME_000.mcap, NAME_001.mcap, ... until SIGINT/SIGTERM, then closes the last file
// (summary and footer) and prints a summary: messages, bytes, dropped and malformed per topic.
// --calibration-from copies the LiDAR-IMU extrinsic of a recording or sequence directory into
// every file (DDS does not carry it), so a replay uses the same extrinsic as the original run.
// Replay a recording with fuse-ingest / fuse-launch --input DIR/NAME_000.mcap. Beside the topics,
// each file holds the Foxglove channels fuse-viz serves (JSON with JSON Schemas; --foxglove off
// leaves them out), so that it opens in Foxglove or Lichtblick and draws the map, scan and path.
// Exit codes: 0 recorded and closed; 1 runtime failure (output, DDS); 2 usage or config.
#include <charconv>
#include <iostream>
#include <limits>
#include <stdexcept>

#include "fuse/core/logging.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/service/runtime.hpp"
#include "recorder.hpp"
#include "topic_filter.hpp"

namespace {

constexpr int kExitOk = 0, kExitFailure = 1, kExitUsage = 2;
constexpr std::size_t kDefaultQueueBytes = 256u << 20;
/// The smallest queue that still holds one sample's bookkeeping.
constexpr std::uint64_t kMinQueueBytes = 1024;
/// How often the main thread looks at the writer's health while waiting for a stop.
constexpr double kSupervisePeriodS = 0.2;

std::uint64_t parse_count(const std::string& name, const std::string& text) {
  std::uint64_t v = 0;
  const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
  if (r.ec != std::errc() || r.ptr != text.data() + text.size()) {
    throw std::invalid_argument("--" + name + " '" + text + "' is not a non-negative integer");
  }
  return v;
}

double parse_seconds(const std::string& name, const std::string& text) {
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || !(v >= 0.0) || v > std::numeric_limits<float>::max()) {
    throw std::invalid_argument("--" + name + " '" + text + "' is not a non-negative number of seconds");
  }
  return v;
}

fuse::io::Compression parse_compression(const std::string& text) {
  if (text == "zstd") return fuse::io::Compression::kZstd;
  if (text == "lz4") return fuse::io::Compression::kLz4;
  if (text == "none") return fuse::io::Compression::kNone;
  throw std::invalid_argument("--compression '" + text + "': expected zstd, lz4 or none");
}

void print_summary(const fuse::record::Recorder& r) {
  std::uint64_t messages = 0, bytes = 0, dropped = 0, malformed = 0;
  std::cout << "fuse-record summary\n";
  for (const auto& f : r.files()) {
    std::cout << "file " << f.path << ": " << f.messages << " messages, " << f.bytes << " bytes";
    if (f.extra_messages > 0) std::cout << " (and " << f.extra_messages << " on the Foxglove channels)";
    std::cout << "\n";
  }
  for (const auto& t : r.stats()) {
    std::cout << "topic " << t.topic << ": " << t.written << " messages, " << t.bytes << " bytes, " << t.dropped
              << " dropped, " << t.malformed << " malformed\n";
    messages += t.written;
    bytes += t.bytes;
    dropped += t.dropped;
    malformed += t.malformed;
  }
  std::cout << "total: " << messages << " messages, " << bytes << " bytes, " << dropped << " dropped, " << malformed
            << " malformed, " << r.files().size() << " files, queue peak " << r.queue_peak_bytes() << " bytes, "
            << r.foxglove_skipped() << " recorded but not drawn on the Foxglove channels\n";
  std::cout.flush();
}

}  // namespace

int main(int argc, char** argv) {
  using namespace fuse;
  service::ServiceArgs args;
  service::SystemConfig config;
  int exit_code = 0;
  const service::ServiceCli cli{
      "fuse-record",
      "Records FUSE-SLAM's DDS topics into MCAP files (DIR/NAME_000.mcap, NAME_001.mcap, ...) until SIGINT or "
      "SIGTERM, then closes the last file and prints a summary per topic. Log times are on the sensor clock.",
      {{"out", "DIR", "output directory (default recording)"},
       {"prefix", "NAME", "file name prefix (default recording)"},
       {"include", "PATTERNS", "comma-separated topic globs to record (default: all)"},
       {"exclude", "PATTERNS", "comma-separated topic globs not to record"},
       {"max-bytes", "N", "start a new file after N bytes"},
       {"max-seconds", "S", "start a new file after S seconds"},
       {"queue-bytes", "N", "bytes held for the writer before samples are dropped (counted)"},
       {"compression", "zstd|lz4|none", "chunk compression (default zstd)"},
       {"calibration-from", "INPUT", "copy the LiDAR-IMU extrinsic of a recording into every file"},
       {"foxglove", "on|off",
        "also write the Foxglove channels fuse-viz serves (/fuse/pose, /tf, /fuse/scan, /fuse/map, ...), so that "
        "the recording draws in Foxglove's 3D panel (default on)"}},
      "Exit codes: 0 recorded and closed, 1 runtime failure (output, DDS), 2 usage or config error."};
  if (!service::start_service(cli, argc, argv, args, config, exit_code)) {
    return exit_code;
  }
  auto log = logger("record");
  std::vector<const record::TopicType*> chosen;
  record::RotationOptions output;
  std::uint64_t queue_bytes = kDefaultQueueBytes;
  std::optional<record::FoxgloveRecording> foxglove;
  try {
    const record::TopicFilter filter(record::split_patterns(args.get("include")), record::split_patterns(args.get("exclude")));
    std::vector<std::string> known;
    for (const auto& t : record::fuse_topics()) {
      known.push_back(t.topic);
      if (filter.accepts(t.topic)) chosen.push_back(&t);
    }
    for (const auto& p : filter.unmatched(known)) log->warn("topic pattern '{}' matches no FUSE topic", p);
    if (chosen.empty()) throw std::invalid_argument("the include/exclude patterns leave no topic to record");
    output.dir = args.get("out", "recording");
    output.prefix = args.get("prefix", "recording");
    if (output.prefix.empty() || output.prefix.find('/') != std::string::npos) {
      throw std::invalid_argument("--prefix '" + output.prefix + "' must be a non-empty file name without '/'");
    }
    output.max_bytes = parse_count("max-bytes", args.get("max-bytes", "0"));
    output.max_seconds = parse_seconds("max-seconds", args.get("max-seconds", "0"));
    output.compression = parse_compression(args.get("compression", "zstd"));
    queue_bytes = parse_count("queue-bytes", args.get("queue-bytes", std::to_string(kDefaultQueueBytes)));
    if (queue_bytes < kMinQueueBytes) {
      throw std::invalid_argument("--queue-bytes " + std::to_string(queue_bytes) + " is below the minimum " +
                                  std::to_string(kMinQueueBytes));
    }
    if (const std::string input = args.get("calibration-from"); !input.empty()) {
      output.calibration = io::open_sensor_source(input)->T_imu_lidar();
      if (!output.calibration) throw std::invalid_argument("--calibration-from '" + input + "' holds no calibration");
    }
    const std::string draw = args.get("foxglove", "on");
    if (draw != "on" && draw != "off") throw std::invalid_argument("--foxglove '" + draw + "' must be on or off");
    if (draw == "on") {
      foxglove = record::FoxgloveRecording{config.viz, output.calibration.value_or(config.estimator.T_imu_lidar)};
      output.extra_channels = service::FoxgloveView::channels();
    }
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return kExitUsage;
  }

  try {
    auto participant = transport::make_participant(config.transport, "fuse-record");
    record::Recorder recorder(*participant, chosen, output, queue_bytes, foxglove);
    std::string names;
    for (const auto* t : chosen) names += (names.empty() ? "" : " ") + t->topic;
    log->info("recording {} topics: {}", chosen.size(), names);
    while (!service::wait_for_stop(kSupervisePeriodS)) {
      if (recorder.failed()) break;
    }
    log->info("stopping: writing what is queued and closing the file");
    recorder.stop();
    print_summary(recorder);
    if (recorder.failed()) {
      log->error("recording failed: {}", recorder.error());
      return kExitFailure;
    }
  } catch (const std::exception& e) {
    log->error("{}", e.what());
    return kExitFailure;
  }
  return kExitOk;
}

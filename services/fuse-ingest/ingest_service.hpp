// fuse-ingest (DESIGN §2): replays a recording (MCAP), a sequence directory or an Ouster pcap
// capture onto `imu` and `lidar/scan`, or publishes a live sensor's data (Ouster or Livox over
// UDP, see ingest_input.hpp) as it arrives. Replays run in one of two modes:
//   realtime: each event at its time on a wall-clock schedule, t_wall = start + (t − t0) / rate.
//             A fixed --start-wall makes a restarted ingest resume where the schedule is now:
//             what played while it was down is a data gap, as with a real sensor;
//   lockstep: as fast as the pipeline goes, publishing the next scan only once fuse-update has
//             answered the previous one (and the IMU after that scan's end is out), so a
//             recording gives the same trajectory on every run as the single-process fuse-run.
// The source's checks count and drop bad input (io::SourceValidator); the counts go to health.
#pragma once

#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "fuse/core/counters.hpp"
#include "fuse/io/sensor_source.hpp"
#include "fuse/service/health.hpp"
#include "fuse/service/system_config.hpp"
#include "fuse/transport/rpc.hpp"
#include "ingest_input.hpp"

namespace fuse::service {

struct IngestOptions {
  IngestInput input;
  std::string mode;                     ///< lockstep | realtime
  double rate = 1.0;
  std::optional<double> start_wall;     ///< realtime: UNIX seconds at which the first event plays
};

class IngestService {
 public:
  IngestService(const SystemConfig& config, transport::Participant& participant, IngestOptions options);
  /// Replays to the end (or until a stop is requested). Returns the process exit code.
  int run();

 private:
  bool wait_for_pipeline();
  /// Polls `done` (10 ms apart, pinging the watchdog) for at most `seconds` or until a stop is
  /// requested; true once it holds.
  bool wait_alive(double seconds, const std::function<bool()>& done);
  /// Waits (ingest.start_wait_s) until every matched IMU reader has acknowledged what was sent.
  void confirm_imu_readers();
  /// Lockstep: waits until fuse-update has answered the scan ending at t_end.
  void wait_for_correction(double t_end, std::uint64_t sequence);
  void publish(const io::SensorEvent& ev);
  /// Waits (ingest.flush_timeout_s) for every matched reader to acknowledge what was published.
  void flush();
  HealthSnapshot health();

  /// A real-time replay restarted after its --start-wall: positions the source where the
  /// schedule is now (seeking, when the format can, instead of reading the past), notes the
  /// recording's first time and keeps the first event read when it cannot seek.
  std::unique_ptr<io::SensorSource> open_source(transport::Participant& participant);
  bool resuming() const;

  SystemConfig config_;
  IngestOptions options_;
  std::optional<double> t0_;                  ///< the recording's first event time, when read ahead
  std::optional<io::SensorEvent> first_event_;  ///< read ahead and not skipped by a seek
  std::unique_ptr<io::SensorSource> source_;

  std::mutex mutex_;
  std::condition_variable cv_;
  double last_correction_t_ = -1.0;
  std::uint64_t last_correction_sequence_ = 0;
  bool have_correction_ = false;
  std::map<std::string, std::string> service_states_;  ///< from the health topic
  Counters counters_;
  std::string state_ = "starting";

  transport::Publisher<fuse_msgs::ImuSample> imu_;
  transport::Publisher<fuse_msgs::LidarScan> scans_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::Correction>> correction_sub_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::Health>> health_sub_;
  std::unique_ptr<HealthReporter> health_;
};

}  // namespace fuse::service

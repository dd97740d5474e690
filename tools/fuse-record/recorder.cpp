#include "recorder.hpp"

#include <chrono>

#include "fuse/core/logging.hpp"
#include "fuse/io/time_ns.hpp"
#include "fuse/transport/msg_traits.hpp"

namespace fuse::record {
namespace {
/// How long the writer thread waits for a sample before looking at the clock (rotation, stop).
constexpr std::chrono::milliseconds kPollInterval{50};
/// A drop is logged the first time and then every this many times per topic.
constexpr std::uint64_t kDropLogEvery = 1000;
}  // namespace

Recorder::Recorder(transport::Participant& participant, std::vector<const TopicType*> topics,
                   const RotationOptions& output, std::size_t queue_bytes,
                   const std::optional<FoxgloveRecording>& foxglove)
    : topics_(topics), queue_(queue_bytes), writer_(output, topics), foxglove_(foxglove) {
  if (foxglove_) view_.emplace(foxglove_->viz, foxglove_->T_imu_lidar);
  for (std::size_t i = 0; i < topics_.size(); ++i) counters_.push_back(std::make_unique<Counters>());
  thread_ = std::thread([this] { run(); });
  try {
    for (std::size_t i = 0; i < topics_.size(); ++i) {
      const TopicType& t = *topics_[i];
      readers_.push_back(participant.create_reader(
          t.topic, t.support, t.qos, [this, i](const std::uint8_t* data, std::size_t size) { on_sample(i, data, size); }));
    }
  } catch (...) {
    stop();
    throw;
  }
}

Recorder::~Recorder() {
  try {
    stop();
  } catch (const std::exception& e) {
    logger("record")->error("stopping: {}", e.what());
  }
}

namespace {
/// Samples without a sensor time held until the first one with it (health and status of a few
/// minutes; more are logged on the host clock).
constexpr std::size_t kMaxHeldBeforeSensorTime = 10000;

std::uint64_t ns_between(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
  const auto d = std::chrono::duration_cast<std::chrono::nanoseconds>(b - a).count();
  return d > 0 ? static_cast<std::uint64_t>(d) : 0;
}

/// t less the host time d (not below 0).
std::uint64_t before(std::uint64_t t, std::chrono::steady_clock::duration d) {
  const auto ns = std::max<std::int64_t>(0, std::chrono::duration_cast<std::chrono::nanoseconds>(d).count());
  return static_cast<std::uint64_t>(ns) < t ? t - static_cast<std::uint64_t>(ns) : 0;
}

/// The host's UTC time (ns) at a steady-clock instant in the past.
std::uint64_t host_realtime_ns(std::chrono::steady_clock::time_point at) {
  const auto now_real = std::chrono::system_clock::now();
  const auto ago = std::chrono::steady_clock::now() - at;
  const auto real = now_real - std::chrono::duration_cast<std::chrono::system_clock::duration>(ago);
  return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(real.time_since_epoch()).count());
}
}  // namespace

void Recorder::on_sample(std::size_t topic, const std::uint8_t* data, std::size_t size) {
  Counters& c = *counters_[topic];
  ++c.received;
  if (queue_.push(topic, data, size)) return;
  const std::uint64_t n = ++c.dropped;
  if (n == 1 || n % kDropLogEvery == 0) {
    logger("record")->warn("queue full ({} of {} bytes): sample of {} bytes on '{}' dropped ({} so far on this topic)",
                           queue_.bytes(), queue_.capacity(), size, topics_[topic]->topic, n);
  }
}

void Recorder::write(const QueuedSample& s) {
  const TopicType& t = *topics_[s.topic];
  Counters& c = *counters_[s.topic];
  const SampleCheck check = t.check(s.data.data(), s.data.size());
  if (!check.ok) {
    const std::uint64_t n = ++c.malformed;
    if (n == 1 || n % kDropLogEvery == 0) {
      logger("record")->warn("malformed sample on '{}' not recorded ({} so far): {}", t.topic, n, check.error);
    }
    return;
  }
  // A stamp of 0 is a message that has no time yet (an estimate before initialisation).
  if (check.sensor_time && *check.sensor_time > 0.0) {
    const std::uint64_t t = io::seconds_to_ns(*check.sensor_time);  // checked representable by the catalog
    if (!anchor_) {
      for (const QueuedSample& held : before_anchor_) put(held, before(t, s.received - held.received));
      before_anchor_.clear();
    }
    // A sensor stamp behind the newest (another sensor's clock, a replayed burst) is logged as
    // stamped; the anchor only moves forward.
    if (!anchor_ || t >= anchor_->first) anchor_ = std::make_pair(t, s.received);
    put(s, t);
    return;
  }
  if (!anchor_) {
    // Nothing on the sensor clock yet (health and status come before the data): held, bounded.
    if (before_anchor_.size() < kMaxHeldBeforeSensorTime) {
      before_anchor_.push_back(s);
      return;
    }
    if (!host_clock_warned_) {
      host_clock_warned_ = true;
      logger("record")->warn("{} samples without a sensor time and none with one yet: the next are logged on the "
                             "host's UTC clock until a sensor time arrives",
                             kMaxHeldBeforeSensorTime);
    }
    put(s, host_realtime_ns(s.received));
    return;
  }
  put(s, anchor_->first + ns_between(anchor_->second, s.received));
}

void Recorder::put(const QueuedSample& s, std::uint64_t log_time) {
  Counters& c = *counters_[s.topic];
  {
    std::lock_guard<std::mutex> lock(mutex_);
    writer_.write(s.topic, log_time, s.data.data(), s.data.size());
  }
  ++c.written;
  c.bytes += s.data.size();
  if (view_) draw(s, log_time);
}

namespace {
template <class T>
T decoded(const QueuedSample& s) {
  T msg;
  std::string error;
  if (!transport::deserialize(s.data.data(), s.data.size(), msg, &error)) throw std::runtime_error(error);
  return msg;
}
std::uint64_t ns_of(double seconds) { return static_cast<std::uint64_t>(seconds * 1e9); }
}  // namespace

void Recorder::write_foxglove(const service::FoxgloveMessage& m, std::uint64_t log_time) {
  std::lock_guard<std::mutex> lock(mutex_);
  writer_.write_extra(static_cast<std::size_t>(m.topic) - 1, log_time, m.payload);
}

void Recorder::draw(const QueuedSample& s, std::uint64_t log_time) {
  namespace topics = transport::topics;
  const std::string& topic = topics_[s.topic]->topic;
  last_log_ns_ = std::max(last_log_ns_, log_time);
  std::vector<service::FoxgloveMessage> out;
  try {
    if (topic == topics::kOdometry) {
      out = view_->odometry(decoded<fuse_msgs::StateEstimate>(s));
    } else if (topic == topics::kCorrected) {
      out.push_back(view_->corrected(decoded<fuse_msgs::StateEstimate>(s)));
    } else if (topic == topics::kWorldScan) {
      out.push_back(view_->world_scan(decoded<fuse_msgs::WorldScan>(s)));
    } else if (topic == topics::kMapChunk) {
      view_->chunk(decoded<fuse_msgs::MapChunk>(s));
    } else if (topic == topics::kHealth) {
      out.push_back(view_->health(decoded<fuse_msgs::Health>(s)));
    }
  } catch (const std::exception& e) {
    // The sample itself is recorded; only its drawing is missing (a pose that is not a rotation).
    const std::uint64_t n = ++foxglove_skipped_;
    if (n == 1 || n % kDropLogEvery == 0) {
      logger("record")->warn("a sample on '{}' has no Foxglove form ({} so far): {}", topic, n, e.what());
    }
  }
  if (!static_written_ && anchor_) {
    // The static transforms once the log has a sensor time (the writer repeats them in every file).
    write_foxglove(view_->static_transforms(static_cast<double>(log_time) * 1e-9), log_time);
    static_written_ = true;
  }
  for (const auto& m : out) write_foxglove(m, log_time);
  draw_periodic(log_time, false);
}

void Recorder::draw_periodic(std::uint64_t log_time, bool final) {
  if (final || log_time >= next_map_ns_) {
    if (auto m = view_->map_if_changed()) {
      write_foxglove(*m, log_time);
      next_map_ns_ = log_time + ns_of(foxglove_->viz.map_period_s);
    }
  }
  if (final || log_time >= next_trajectory_ns_) {
    if (auto m = view_->trajectory_if_changed()) {
      write_foxglove(*m, log_time);
      next_trajectory_ns_ = log_time + ns_of(foxglove_->viz.trajectory_period_s);
    }
  }
}

void Recorder::run() {
  try {
    for (;;) {
      if (auto s = queue_.pop(kPollInterval)) {
        write(*s);
        continue;
      }
      if (stopping_) break;  // the readers are gone and the queue is empty
      std::lock_guard<std::mutex> lock(mutex_);
      writer_.rotate_if_due(std::chrono::steady_clock::now());
    }
  } catch (const std::exception& e) {
    std::lock_guard<std::mutex> lock(mutex_);
    error_ = e.what();
    failed_ = true;
    logger("record")->error("writing the recording failed: {}", e.what());
  }
}

void Recorder::stop() {
  if (stopped_) return;
  stopped_ = true;
  readers_.clear();  // no callback runs after this
  stopping_ = true;
  if (thread_.joinable()) thread_.join();
  // No sensor time came at all: what was held is logged on the host's clock (UTC).
  try {
    for (const QueuedSample& held : before_anchor_) put(held, host_realtime_ns(held.received));
  } catch (const std::exception& e) {
    std::lock_guard<std::mutex> lock(mutex_);
    error_ = e.what();
    failed_ = true;
  }
  before_anchor_.clear();
  try {
    if (view_ && last_log_ns_ > 0) draw_periodic(last_log_ns_, true);  // the last map and trajectory
  } catch (const std::exception& e) {
    std::lock_guard<std::mutex> lock(mutex_);
    error_ = e.what();
    failed_ = true;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  writer_.close();
}

std::string Recorder::error() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return error_;
}

std::vector<TopicStats> Recorder::stats() const {
  std::vector<TopicStats> out;
  for (std::size_t i = 0; i < topics_.size(); ++i) {
    const Counters& c = *counters_[i];
    out.push_back(TopicStats{topics_[i]->topic, c.received, c.dropped, c.malformed, c.written, c.bytes});
  }
  return out;
}

std::vector<FileSummary> Recorder::files() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return writer_.files();
}

}  // namespace fuse::record

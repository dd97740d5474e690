#include "recorder.hpp"

#include <chrono>

#include "fuse/core/logging.hpp"
#include "fuse/io/time_ns.hpp"

namespace fuse::record {
namespace {
/// How long the writer thread waits for a sample before looking at the clock (rotation, stop).
constexpr std::chrono::milliseconds kPollInterval{50};
/// A drop is logged the first time and then every this many times per topic.
constexpr std::uint64_t kDropLogEvery = 1000;
}  // namespace

Recorder::Recorder(transport::Participant& participant, std::vector<const TopicType*> topics,
                   const RotationOptions& output, std::size_t queue_bytes)
    : topics_(topics), queue_(queue_bytes), writer_(output, topics) {
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
  std::uint64_t log_time = clock_ns_;
  if (check.sensor_time) {
    log_time = io::seconds_to_ns(*check.sensor_time);  // checked representable by the catalog
    clock_ns_ = std::max(clock_ns_, log_time);
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    writer_.write(s.topic, log_time, s.data.data(), s.data.size());
  }
  ++c.written;
  c.bytes += s.data.size();
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

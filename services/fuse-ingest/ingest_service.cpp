#include "ingest_service.hpp"

#include <chrono>
#include <cmath>
#include <thread>

#include "fuse/core/logging.hpp"
#include "fuse/io/prefetch_source.hpp"
#include "fuse/service/convert.hpp"
#include "fuse/service/notify.hpp"
#include "fuse/service/runtime.hpp"

namespace fuse::service {

namespace {
constexpr const char* kName = "fuse-ingest";
constexpr const char* kFrameImu = "imu";
constexpr const char* kFrameLidar = "lidar";

double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}
}  // namespace

IngestService::IngestService(const SystemConfig& config, transport::Participant& participant, IngestOptions options)
    : config_(config),
      options_(std::move(options)),
      source_(std::make_unique<io::PrefetchSource>(open_source(participant), static_cast<std::size_t>(config.ingest.prefetch_events))),
      counters_(logger(kName)),
      imu_(participant, transport::topics::kImu, config.ingest.held_imu),
      scans_(participant, transport::topics::kLidarScan, config.ingest.held_scans) {
  correction_sub_ = std::make_unique<transport::Subscriber<fuse_msgs::Correction>>(
      participant, transport::topics::kCorrection, [this](const fuse_msgs::Correction& c) {
        {
          std::lock_guard<std::mutex> lock(mutex_);
          if (std::isfinite(c.t())) last_correction_t_ = std::max(last_correction_t_, c.t());
          last_correction_sequence_ = c.scan_sequence();
          have_correction_ = true;
        }
        cv_.notify_all();
      });
  health_sub_ = std::make_unique<transport::Subscriber<fuse_msgs::Health>>(
      participant, transport::topics::kHealth, [this](const fuse_msgs::Health& h) {
        std::lock_guard<std::mutex> lock(mutex_);
        service_states_[h.service().to_string()] = h.state().to_string();
      });
  health_ = std::make_unique<HealthReporter>(participant, kName, config.health.period_s, config.health.instance_window_s, [this] { return health(); });
  if (options_.input.live()) {
    logger(kName)->info("publishing {} live, as it arrives", source_->describe());
  } else {
    logger(kName)->info("replaying {} ({}{})", source_->describe(), options_.mode,
                        options_.mode == "realtime" ? ", rate " + std::to_string(options_.rate) : "");
  }
}

bool IngestService::resuming() const {
  return options_.mode == "realtime" && !options_.input.live() && options_.start_wall &&
         *options_.start_wall < unix_now();
}

std::unique_ptr<io::SensorSource> IngestService::open_source(transport::Participant& participant) {
  std::unique_ptr<io::SensorSource> source = open_ingest_input(options_.input, config_.estimator.clock, &participant);
  if (!resuming()) return source;
  // Joining a schedule that has run for a while: read the first event (the schedule's origin),
  // then jump to where the schedule is now. Reading and dropping everything before took seconds
  // into a long recording, all of it a data gap that a restarted sensor driver would not have.
  io::SensorEvent first;
  if (!source->next(first)) return source;
  t0_ = first.arrival_time();
  const double now_t = *t0_ + (unix_now() - *options_.start_wall) * options_.rate - config_.ingest.max_lateness_s;
  if (now_t > *t0_ && source->seek(now_t)) {
    logger(kName)->info("resuming the schedule at t={:.3f} ({:.1f} s into the recording): the events before it are "
                        "a data gap",
                        now_t, now_t - *t0_);
  } else {
    first_event_ = std::move(first);
  }
  return source;
}

bool IngestService::wait_for_pipeline() {
  // fuse-state must be past its recovery wait and fuse-update's replica synchronised, or the
  // first scans would be skipped for reasons that have nothing to do with the data.
  const std::size_t readers = 1 + static_cast<std::size_t>(config_.ingest.extra_readers);
  return wait_alive(config_.ingest.start_wait_s, [this, readers] {
    std::lock_guard<std::mutex> lock(mutex_);
    auto s = service_states_.find("fuse-state");
    auto u = service_states_.find("fuse-update");
    return s != service_states_.end() && s->second != "starting" && u != service_states_.end() &&
           u->second != "starting" && imu_.matched() >= readers && scans_.matched() >= readers;
  });
}

bool IngestService::wait_alive(double seconds, const std::function<bool()>& done) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end && !stop_requested()) {
    if (done()) return true;
    notifier().watchdog();
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

void IngestService::publish(const io::SensorEvent& ev) {
  if (ev.kind == io::SensorEvent::Kind::kImu) {
    imu_.publish(to_msg(ev.imu, kFrameImu));
  } else {
    scans_.publish_serialized(scan_to_wire(ev.scan, kFrameLidar));
  }
  std::lock_guard<std::mutex> lock(mutex_);
  counters_.add(ev.kind == io::SensorEvent::Kind::kImu ? "imu_published" : "scans_published");
}

void IngestService::confirm_imu_readers() {
  // A matched reader on our side is not yet a reader that has matched us: discovery runs each
  // way separately and a lost announcement is repeated only at the next heartbeat (seconds on
  // Fast DDS). Until fuse-state has matched this writer it drops what we send, and a lockstep
  // replay whose scans are all answered 'not initialised' runs ahead by more than the topic's
  // depth, so fuse-state would miss the stationary start it initialises from. (In real time the
  // depth holds seconds of IMU, longer than discovery takes.) The first sample's acknowledgment
  // shows that every matched reader has matched back.
  if (wait_alive(config_.ingest.start_wait_s, [this] { return imu_.wait_for_acknowledgments(std::chrono::milliseconds(50)); }) ||
      stop_requested()) {
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  counters_.count("imu_unacknowledged", "the IMU readers did not acknowledge the first sample within "
                                        "ingest.start_wait_s: replaying anyway");
}

void IngestService::wait_for_correction(double t_end, std::uint64_t sequence) {
  std::unique_lock<std::mutex> lock(mutex_);
  const bool answered = cv_.wait_for(lock, std::chrono::duration<double>(config_.ingest.lockstep_timeout_s), [&] {
    return stop_requested() || last_correction_t_ >= t_end - 1e-9 ||
           (have_correction_ && last_correction_sequence_ == sequence && !std::isfinite(t_end));
  });
  if (!answered) {
    counters_.count("correction_timeout", "no answer from fuse-update for the scan ending at t=" + std::to_string(t_end) +
                                              " within ingest.lockstep_timeout_s: going on");
  }
}

int IngestService::run() {
  auto log = logger(kName);
  // A restarted real-time replay joins a schedule already running: it plays at once (the IMU
  // topic is transient-local, so what it publishes before discovery completes still arrives).
  if (!resuming() && !wait_for_pipeline()) {
    if (stop_requested()) return 0;
    log->warn("fuse-state / fuse-update not ready after {:.1f} s: replaying anyway", config_.ingest.start_wait_s);
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.add("started_without_pipeline");
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    state_ = "running";
  }
  // A live sensor is published as it arrives: no schedule, no lockstep.
  const bool live = options_.input.live();
  const bool lockstep = options_.mode == "lockstep" && !live;
  // A restarted lockstep replay resumes after the last scan fuse-update answered.
  double resume_after = -1.0;
  if (lockstep) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (have_correction_) resume_after = last_correction_t_;
  }
  if (resume_after > 0.0) log->info("resuming after t={:.3f} (the last answered scan)", resume_after);

  io::SensorEvent ev;
  std::optional<double> t0 = t0_;
  double wall0 = options_.start_wall.value_or(unix_now());
  bool pending = false;  // lockstep: a scan awaits its answer
  double last_imu_t = -1.0;  // lockstep: the newest IMU sample published
  double pending_t = 0.0;
  std::uint64_t pending_sequence = 0;
  std::size_t skipped = 0;
  bool confirmed = !lockstep;  // lockstep: the IMU readers have acknowledged the first sample
  try {
    auto next_event = [this](io::SensorEvent& e) {
      if (!first_event_) return source_->next(e);
      e = std::move(*first_event_);
      first_event_.reset();
      return true;
    };
    while (!stop_requested() && next_event(ev)) {
      notifier().watchdog();
      const double t = ev.arrival_time();
      if (!t0) t0 = t;
      if (live) {
        publish(ev);
        continue;
      }
      if (lockstep) {
        if (t <= resume_after) {
          ++skipped;
          continue;
        }
        if (ev.kind == io::SensorEvent::Kind::kLidar && pending) {
          wait_for_correction(pending_t, pending_sequence);
          pending = false;
        }
        // The IMU sample that ends a data gap decides how fuse-state coasts across it: fuse-run
        // has the scan inside the gap processed (coasted to its end) before it sees that sample,
        // so it must not overtake the scan's history request here either.
        if (ev.kind == io::SensorEvent::Kind::kImu && pending && ev.imu.t > pending_t && last_imu_t >= 0.0 &&
            ev.imu.t - last_imu_t > config_.estimator.divergence.max_imu_gap) {
          wait_for_correction(pending_t, pending_sequence);
          pending = false;
        }
        if (ev.kind == io::SensorEvent::Kind::kImu) last_imu_t = ev.imu.t;
        publish(ev);
        if (!confirmed && ev.kind == io::SensorEvent::Kind::kImu) {
          confirm_imu_readers();
          confirmed = true;
        }
        if (ev.kind == io::SensorEvent::Kind::kLidar) {
          pending = true;
          pending_t = ev.scan.t_end;
          pending_sequence = ev.scan.sequence;
        } else if (pending && ev.imu.t > pending_t) {
          wait_for_correction(pending_t, pending_sequence);
          pending = false;
        }
        continue;
      }
      const double due = wall0 + (t - *t0) / options_.rate;
      const double wait = due - unix_now();
      // Far behind the schedule: a restarted ingest joining it, the events of its downtime are a
      // data gap, as with a real sensor. A little behind (the machine was busy for a moment): a
      // driver would deliver late, not drop, so publish at once and catch up.
      if (wait < -config_.ingest.max_lateness_s) {
        ++skipped;
        continue;
      }
      if (wait > 0.0 && wait_for_stop_alive(wait)) break;
      publish(ev);
    }
    if (pending) wait_for_correction(pending_t, pending_sequence);
    if (!lockstep && !stop_requested()) wait_for_stop(0.5);  // let the last scan's answer come back
  } catch (const io::InputError& e) {
    log->error("input error: {}", e.what());
    flush();  // what was published before the error still reaches its readers
    return kExitInput;
  }
  flush();
  if (skipped > 0) log->info("{} events skipped (before the resume point or behind the schedule)", skipped);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.add("events_skipped", skipped);
    state_ = "stopping";
  }
  health_->publish_now();
  std::lock_guard<std::mutex> lock(mutex_);  // health() reads the source's stats too
  const io::SourceStats stats = source_->stats();
  for (const auto& [reason, n] : stats.rejected) log->warn("input refused: {} x{}", reason, n);
  log->info("replay done: {} IMU samples, {} scans", stats.imu_samples, stats.scans);
  return 0;
}

void IngestService::flush() {
  const auto timeout = std::chrono::milliseconds(static_cast<long>(config_.ingest.flush_timeout_s * 1000.0));
  const bool imu = imu_.wait_for_acknowledgments(timeout);
  const bool scans = scans_.wait_for_acknowledgments(timeout);
  if (!imu || !scans) {
    std::lock_guard<std::mutex> lock(mutex_);
    counters_.count("flush_timeout", "not every matched reader acknowledged what was published within "
                                     "ingest.flush_timeout_s: it may miss the last samples");
  }
}

HealthSnapshot IngestService::health() {
  std::lock_guard<std::mutex> lock(mutex_);
  HealthSnapshot s;
  s.state = state_;
  s.counters = counters_.map();
  for (const auto& [reason, n] : source_->stats().rejected) s.counters["input_" + reason] = n;
  return s;
}

}  // namespace fuse::service

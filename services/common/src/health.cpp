#include "fuse/service/health.hpp"

#include "fuse/core/logging.hpp"
#include "fuse/transport/rpc.hpp"

namespace fuse::service {

HealthReporter::HealthReporter(transport::Participant& participant, std::string service, double period_s,
                               double instance_window_s, std::function<HealthSnapshot()> snapshot)
    : service_(std::move(service)),
      instance_(transport::random_id()),
      start_(std::chrono::steady_clock::now()),
      period_(period_s),
      snapshot_(std::move(snapshot)),
      publisher_(participant, transport::topics::kHealth),
      watch_(instance_window_s),
      subscriber_(std::make_unique<transport::Subscriber<fuse_msgs::Health>>(
          participant, transport::topics::kHealth, [this](const fuse_msgs::Health& h) { on_health(h); })),
      thread_([this] { run(); }) {}

void HealthReporter::on_health(const fuse_msgs::Health& h) {
  std::lock_guard<std::mutex> lock(watch_mutex_);
  watch_.heard(h.service().to_string(), h.instance(), InstanceWatch::Clock::now());
}

std::string HealthReporter::duplicate(const std::string& service) const {
  std::lock_guard<std::mutex> lock(watch_mutex_);
  const auto ids = watch_.concurrent(service, InstanceWatch::Clock::now());
  return ids.empty() ? "" : describe_duplicate(service, ids);
}

HealthReporter::~HealthReporter() {
  subscriber_.reset();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

void HealthReporter::publish_now() {
  HealthSnapshot s = snapshot_();
  {
    std::lock_guard<std::mutex> lock(sink_mutex_);
    if (amend_) amend_(s);
  }
  const std::string twice = duplicate(service_);
  if (!twice.empty()) {
    if (s.state != "stopping") s.state = "degraded";
    s.counters["duplicate_instances"] = 1;
    s.last_error = twice;
  }
  const bool duplicated = !twice.empty();
  if (reported_duplicate_.exchange(duplicated) != duplicated) {
    if (duplicated) {
      logger(service_)->error("{}", twice);
    } else {
      logger(service_)->info("only this instance of {} is alive again", service_);
    }
  }
  fuse_msgs::Health m;
  m.service(service_.substr(0, 32));
  m.instance(instance_);
  m.sequence_number(++sequence_);
  m.uptime_s(std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count());
  m.state(s.state.substr(0, 32));
  for (const auto& [name, value] : s.counters) {
    if (m.counters().size() >= 128) break;
    fuse_msgs::Counter c;
    c.name(name.substr(0, 64));
    c.value(value);
    m.counters().push_back(c);
  }
  m.last_error(s.last_error.substr(0, 256));
  publisher_.publish(m);
  std::lock_guard<std::mutex> lock(sink_mutex_);
  if (sink_) sink_(m);
}

void HealthReporter::also_publish(std::function<void(const fuse_msgs::Health&)> sink,
                                  std::function<void(HealthSnapshot&)> amend) {
  std::lock_guard<std::mutex> lock(sink_mutex_);
  sink_ = std::move(sink);
  amend_ = std::move(amend);
}

void HealthReporter::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stop_) {
    lock.unlock();
    publish_now();
    lock.lock();
    cv_.wait_for(lock, period_, [this] { return stop_; });
  }
}

}  // namespace fuse::service

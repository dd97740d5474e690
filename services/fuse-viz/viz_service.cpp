// fuse-viz's DDS side (viz_service.hpp).
#include "viz_service.hpp"

#include <chrono>

#include "fuse/core/logging.hpp"
#include "fuse/foxglove/messages.hpp"

namespace fuse::viz {
namespace {

constexpr double kBytesPerMiB = 1024.0 * 1024.0;
constexpr auto kPeriodicTick = std::chrono::milliseconds(100);

foxglove::ServerConfig server_config(const service::VizConfig& c) {
  foxglove::ServerConfig s;
  s.address = c.address;
  s.port = static_cast<std::uint16_t>(c.port);
  s.max_client_queue_bytes = static_cast<std::size_t>(c.max_client_queue_mb * kBytesPerMiB);
  s.max_client_backlog_s = c.max_client_backlog_s;
  s.max_clients = static_cast<std::size_t>(c.max_clients);
  s.name = "fuse-viz";
  return s;
}

std::chrono::steady_clock::duration seconds(double s) {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(s));
}

}  // namespace

VizService::VizService(const service::SystemConfig& config, transport::Participant& participant)
    : config_(config.viz),
      participant_(participant),
      server_(server_config(config.viz), service::FoxgloveView::channels()),
      view_(config.viz, config.estimator.T_imu_lidar) {
  logger("fuse-viz")->info("serving Foxglove WebSocket (foxglove.websocket.v1) on ws://{}:{}", config_.address, port());
  send(view_.static_transforms(0.0));  // latched: every client gets the static part of the tree
  server_.on_subscribe([this](foxglove::ChannelId channel) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (channel == static_cast<foxglove::ChannelId>(Topic::kMap)) map_requested_ = true;
      if (channel == static_cast<foxglove::ChannelId>(Topic::kTrajectory)) trajectory_requested_ = true;
    }
    wake_.notify_all();
  });
  using transport::Subscriber;
  namespace topics = transport::topics;
  using Messages = std::vector<service::FoxgloveMessage>;
  // Every scan-rate pose joins the trajectory: deeper than the table's depth 1, which is for a late joiner.
  constexpr int kCorrectedDepth = 100;
  corrected_ = std::make_unique<Subscriber<fuse_msgs::StateEstimate>>(
      participant, topics::kCorrected, kCorrectedDepth,
      guarded(topics::kCorrected, [this](const fuse_msgs::StateEstimate& s) { return Messages{view_.corrected(s)}; }),
      bad(topics::kCorrected));
  chunks_ = std::make_unique<Subscriber<fuse_msgs::MapChunk>>(
      participant, topics::kMapChunk, guarded(topics::kMapChunk, [this](const fuse_msgs::MapChunk& c) {
        view_.chunk(c);
        return Messages{};
      }),
      bad(topics::kMapChunk));
  health_ = std::make_unique<Subscriber<fuse_msgs::Health>>(
      participant, topics::kHealth, guarded(topics::kHealth, [this](const fuse_msgs::Health& h) {
        return wanted(Topic::kHealth) ? Messages{view_.health(h)} : Messages{};
      }),
      bad(topics::kHealth));
  periodic_ = std::thread([this] { run_periodic(); });  // also makes the odometry and scan readers on demand
}

VizService::~VizService() { stop(); }

void VizService::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (periodic_.joinable()) periodic_.join();  // before odometry_ and world_scans_, which that thread owns
  odometry_.reset();
  world_scans_.reset();
  corrected_.reset();
  chunks_.reset();
  health_.reset();
  server_.stop();
}

void VizService::follow_demand() {
  namespace topics = transport::topics;
  using Messages = std::vector<service::FoxgloveMessage>;
  follow(odometry_, wanted(Topic::kPose) || wanted(Topic::kTf), topics::kOdometry, "/fuse/pose or /tf",
         [this](const fuse_msgs::StateEstimate& s) { return view_.odometry(s, wanted(Topic::kPose), wanted(Topic::kTf)); });
  follow(world_scans_, wanted(Topic::kScan), topics::kWorldScan, "/fuse/scan", [this](const fuse_msgs::WorldScan& s) {
    return wanted(Topic::kScan) ? Messages{view_.world_scan(s)} : Messages{};
  });
}

void VizService::send(const service::FoxgloveMessage& m) {
  server_.publish(static_cast<foxglove::ChannelId>(m.topic), foxglove::to_nanoseconds(m.t), m.payload);
}

void VizService::malformed(const std::string& topic, const std::string& reason) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++counters_["samples_malformed"];
  last_error_ = "malformed sample on " + topic + ": " + reason;
  logger("fuse-viz")->warn("{}", last_error_);
}

void VizService::run_periodic() {
  using Clock = std::chrono::steady_clock;
  Clock::time_point next_map = Clock::now(), next_trajectory = Clock::now();
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, kPeriodicTick);
    if (stopping_) break;
    const Clock::time_point now = Clock::now();
    std::vector<service::FoxgloveMessage> out;
    // Encoded only while someone listens (the view keeps "changed" until then); at once for a
    // client that just subscribed.
    if ((now >= next_map && wanted(Topic::kMap)) || map_requested_) {
      map_requested_ = false;
      if (auto m = view_.map_if_changed()) {
        out.push_back(std::move(*m));
        next_map = now + seconds(config_.map_period_s);
      }
    }
    if ((now >= next_trajectory && wanted(Topic::kTrajectory)) || trajectory_requested_) {
      trajectory_requested_ = false;
      if (auto m = view_.trajectory_if_changed()) {
        out.push_back(std::move(*m));
        next_trajectory = now + seconds(config_.trajectory_period_s);
      }
    }
    lock.unlock();
    for (const auto& m : out) send(m);
    follow_demand();
    lock.lock();
  }
}

service::HealthSnapshot VizService::health() const {
  service::HealthSnapshot h;
  const foxglove::ServerStats s = server_.stats();
  std::lock_guard<std::mutex> lock(mutex_);
  h.counters = counters_;
  h.counters["clients"] = s.clients;
  h.counters["connections"] = s.connections;
  h.counters["connections_refused"] = s.refused;
  h.counters["messages_sent"] = s.messages_sent;
  h.counters["messages_dropped_slow_client"] = s.messages_dropped;
  h.counters["clients_stalled"] = s.clients_stalled;
  h.counters["client_stalls"] = s.stalls;
  h.counters["client_requests_bad"] = s.bad_requests;
  h.counters["trajectory_thinned"] = view_.trajectory_thinned();
  h.last_error = last_error_;
  return h;
}

}  // namespace fuse::viz

// fuse-viz's DDS side (viz_service.hpp).
#include "viz_service.hpp"

#include <chrono>
#include <cmath>

#include "fuse/core/logging.hpp"
#include "fuse/foxglove/messages.hpp"
#include "fuse/service/convert.hpp"

namespace fuse::viz {
namespace {

using foxglove::Channel;
constexpr double kBytesPerMiB = 1024.0 * 1024.0;
constexpr auto kPeriodicTick = std::chrono::milliseconds(100);

Channel json_channel(const std::string& topic, const foxglove::JsonSchema& schema, bool latched = false) {
  return Channel{topic, "json", schema.name, schema.text, "jsonschema", latched};
}

foxglove::ServerConfig server_config(const service::VizConfig& c) {
  foxglove::ServerConfig s;
  s.address = c.address;
  s.port = static_cast<std::uint16_t>(c.port);
  s.max_client_queue_bytes = static_cast<std::size_t>(c.max_client_queue_mb * kBytesPerMiB);
  s.max_clients = static_cast<std::size_t>(c.max_clients);
  s.name = "fuse-viz";
  return s;
}

}  // namespace

std::vector<Channel> viz_channels() {
  using namespace foxglove;
  // In VizChannel order.
  return {json_channel("/fuse/pose", pose_in_frame_schema()),
          json_channel("/fuse/pose_scan", pose_in_frame_schema()),
          json_channel("/tf", frame_transforms_schema()),
          json_channel("/tf_static", frame_transforms_schema(), true),
          json_channel("/fuse/scan", point_cloud_schema()),
          json_channel("/fuse/map", point_cloud_schema(), true),
          json_channel("/fuse/trajectory", poses_in_frame_schema(), true),
          json_channel("/fuse/health", health_schema())};
}

VizService::VizService(const service::SystemConfig& config, transport::Participant& participant)
    : config_(config.viz), T_imu_lidar_(config.estimator.T_imu_lidar), server_(server_config(config.viz), viz_channels()) {
  logger("fuse-viz")->info("serving Foxglove WebSocket (foxglove.websocket.v1) on ws://{}:{}", config_.address, port());
  // The static part of the tree, latched for every client: imu -> lidar from the config.
  publish(VizChannel::kTfStatic, 0.0,
          foxglove::frame_transforms_json({{0.0, config_.imu_frame, config_.lidar_frame, T_imu_lidar_}}));
  periodic_ = std::thread([this] { run_periodic(); });
  using transport::Subscriber;
  namespace topics = transport::topics;
  auto bad = [this](const char* topic) { return [this, topic](const std::string& why) { malformed(topic, why); }; };
  odometry_ = std::make_unique<Subscriber<fuse_msgs::StateEstimate>>(
      participant, topics::kOdometry, [this](const fuse_msgs::StateEstimate& s) { on_odometry(s); }, bad(topics::kOdometry));
  corrected_ = std::make_unique<Subscriber<fuse_msgs::StateEstimate>>(
      participant, topics::kCorrected, [this](const fuse_msgs::StateEstimate& s) { on_corrected(s); },
      bad(topics::kCorrected));
  world_scans_ = std::make_unique<Subscriber<fuse_msgs::WorldScan>>(
      participant, topics::kWorldScan, [this](const fuse_msgs::WorldScan& s) { on_world_scan(s); },
      bad(topics::kWorldScan));
  chunks_reader_ = std::make_unique<Subscriber<fuse_msgs::MapChunk>>(
      participant, topics::kMapChunk, [this](const fuse_msgs::MapChunk& c) { on_chunk(c); }, bad(topics::kMapChunk));
  health_ = std::make_unique<Subscriber<fuse_msgs::Health>>(
      participant, topics::kHealth, [this](const fuse_msgs::Health& h) { on_health(h); }, bad(topics::kHealth));
}

VizService::~VizService() { stop(); }

void VizService::stop() {
  odometry_.reset();
  corrected_.reset();
  world_scans_.reset();
  chunks_reader_.reset();
  health_.reset();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (periodic_.joinable()) periodic_.join();
  server_.stop();
}

void VizService::publish(VizChannel channel, double t, std::string payload) {
  server_.publish(static_cast<foxglove::ChannelId>(channel), foxglove::to_nanoseconds(t), std::move(payload));
}

void VizService::malformed(const std::string& topic, const std::string& reason) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++counters_["samples_malformed"];
  last_error_ = "malformed sample on " + topic + ": " + reason;
  logger("fuse-viz")->warn("{}", last_error_);
}

void VizService::on_odometry(const fuse_msgs::StateEstimate& s) {
  Eigen::Isometry3d T_world_imu;
  try {
    T_world_imu = service::from_pose(s.pose());
  } catch (const std::exception& e) {
    return malformed(transport::topics::kOdometry, e.what());
  }
  latest_t_ = s.t();
  if (server_.has_subscribers(static_cast<foxglove::ChannelId>(VizChannel::kPose))) {
    publish(VizChannel::kPose, s.t(), foxglove::pose_in_frame_json(s.t(), config_.world_frame, T_world_imu));
  }
  if (server_.has_subscribers(static_cast<foxglove::ChannelId>(VizChannel::kTf))) {
    publish(VizChannel::kTf, s.t(),
            foxglove::frame_transforms_json({{s.t(), config_.world_frame, config_.imu_frame, T_world_imu}}));
  }
}

void VizService::on_corrected(const fuse_msgs::StateEstimate& s) {
  Eigen::Isometry3d T_world_imu;
  try {
    T_world_imu = service::from_pose(s.pose());
  } catch (const std::exception& e) {
    return malformed(transport::topics::kCorrected, e.what());
  }
  publish(VizChannel::kPoseScan, s.t(), foxglove::pose_in_frame_json(s.t(), config_.world_frame, T_world_imu));
  std::lock_guard<std::mutex> lock(mutex_);
  if (!trajectory_t_.empty() && s.t() <= trajectory_t_.back()) return;  // a repeat after a restart
  trajectory_.push_back(T_world_imu);
  trajectory_t_.push_back(s.t());
  if (trajectory_.size() > config_.max_trajectory_poses) {
    // Bounded: keep every other pose (the newest stays), and say so once per thinning.
    std::size_t kept = 0;
    for (std::size_t i = trajectory_.size() % 2 == 0 ? 1 : 0; i < trajectory_.size(); i += 2, ++kept) {
      trajectory_[kept] = trajectory_[i];
      trajectory_t_[kept] = trajectory_t_[i];
    }
    trajectory_.resize(kept);
    trajectory_t_.resize(kept);
    ++counters_["trajectory_thinned"];
  }
  trajectory_changed_ = true;
}

void VizService::on_world_scan(const fuse_msgs::WorldScan& s) {
  latest_t_ = std::max(latest_t_.load(), s.t());
  if (!server_.has_subscribers(static_cast<foxglove::ChannelId>(VizChannel::kScan))) return;
  std::vector<float> xyz;
  xyz.reserve(3 * s.points().size());
  for (const fuse_msgs::Point3f& p : s.points()) {
    xyz.push_back(p.x());
    xyz.push_back(p.y());
    xyz.push_back(p.z());
  }
  publish(VizChannel::kScan, s.t(), foxglove::point_cloud_json(s.t(), config_.world_frame, xyz));
}

void VizService::on_chunk(const fuse_msgs::MapChunk& c) {
  std::lock_guard<std::mutex> lock(mutex_);
  Chunk& chunk = chunks_[c.key()];
  // A chunk of an older map (epoch) or an older revision of this one changes nothing.
  if (std::make_pair(c.epoch(), c.revision()) < std::make_pair(chunk.epoch, chunk.revision)) return;
  chunk.epoch = c.epoch();
  chunk.revision = c.revision();
  chunk.xyz.clear();
  chunk.xyz.reserve(3 * c.points().size());
  for (const fuse_msgs::Point3f& p : c.points()) {
    chunk.xyz.push_back(p.x());
    chunk.xyz.push_back(p.y());
    chunk.xyz.push_back(p.z());
  }
  map_changed_ = true;
}

void VizService::on_health(const fuse_msgs::Health& h) {
  if (!server_.has_subscribers(static_cast<foxglove::ChannelId>(VizChannel::kHealth))) return;
  foxglove::HealthView view;
  view.t = latest_t_;
  view.service = h.service();
  view.instance = h.instance();
  view.state = h.state();
  view.uptime_s = h.uptime_s();
  view.last_error = h.last_error();
  for (const fuse_msgs::Counter& c : h.counters()) view.counters[c.name().to_string()] = c.value();
  publish(VizChannel::kHealth, view.t, foxglove::health_json(view));
}

void VizService::run_periodic() {
  using Clock = std::chrono::steady_clock;
  Clock::time_point next_map = Clock::now(), next_trajectory = Clock::now();
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, kPeriodicTick);
    if (stopping_) break;
    const Clock::time_point now = Clock::now();
    const double t = latest_t_;
    if (map_changed_ && now >= next_map) {
      std::vector<float> xyz;
      for (const auto& [key, chunk] : chunks_) xyz.insert(xyz.end(), chunk.xyz.begin(), chunk.xyz.end());
      map_changed_ = false;
      next_map = now + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(config_.map_period_s));
      lock.unlock();  // encoding a large map must not hold up the DDS callbacks
      publish(VizChannel::kMap, t, foxglove::point_cloud_json(t, config_.world_frame, xyz));
      lock.lock();
    }
    if (trajectory_changed_ && now >= next_trajectory) {
      const std::vector<Eigen::Isometry3d> poses = trajectory_;
      const double t_last = trajectory_t_.back();
      trajectory_changed_ = false;
      next_trajectory =
          now + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(config_.trajectory_period_s));
      lock.unlock();
      publish(VizChannel::kTrajectory, t_last, foxglove::poses_in_frame_json(t_last, config_.world_frame, poses));
      lock.lock();
    }
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
  h.counters["client_requests_bad"] = s.bad_requests;
  h.last_error = last_error_;
  return h;
}

}  // namespace fuse::viz

// fuse-viz's transport side: the system's topics read from DDS, turned into Foxglove messages by
// FoxgloveView (fuse/service/foxglove_view.hpp, shared with fuse-record) and served to Foxglove
// clients (fuse/foxglove/server.hpp). The map and the trajectory go out whole, latched, at most
// every viz.map_period_s / viz.trajectory_period_s when they changed (own thread), and only while
// a client subscribes to them: one that subscribes gets the last one sent at once (latched) and a
// current one within a tick.
//
// Every DDS callback encodes and hands the message to the server, which queues it per client
// (bounded, the oldest dropped and counted): a slow client never holds up a DDS thread.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "fuse/core/logging.hpp"
#include "fuse/foxglove/server.hpp"
#include "fuse/service/foxglove_view.hpp"
#include "fuse/service/health.hpp"
#include "fuse/service/system_config.hpp"
#include "fuse/transport/msg_traits.hpp"

namespace fuse::viz {

class VizService {
 public:
  /// Starts the Foxglove server and the DDS readers. Throws std::runtime_error when the address
  /// cannot be bound.
  VizService(const service::SystemConfig& config, transport::Participant& participant);
  ~VizService();
  VizService(const VizService&) = delete;
  VizService& operator=(const VizService&) = delete;

  std::uint16_t port() const { return server_.port(); }
  service::HealthSnapshot health() const;
  void stop();

 private:
  using Topic = service::FoxgloveTopic;
  bool wanted(Topic topic) const { return server_.has_subscribers(static_cast<foxglove::ChannelId>(topic)); }
  void send(const service::FoxgloveMessage& m);
  void malformed(const std::string& topic, const std::string& reason);
  std::function<void(const std::string&)> bad(const char* topic) {
    return [this, topic](const std::string& why) { malformed(topic, why); };
  }
  /// A DDS callback: converts the sample under mutex_ and sends the result outside it
  /// (Server::publish only posts); a sample that does not convert is counted as malformed.
  template <class Convert>
  auto guarded(const char* topic, Convert convert) {
    return [this, topic, convert](const auto& sample) {
      std::vector<service::FoxgloveMessage> out;
      try {
        std::lock_guard<std::mutex> lock(mutex_);
        out = convert(sample);
      } catch (const std::exception& e) {
        return malformed(topic, e.what());
      }
      for (const auto& m : out) send(m);
    };
  }
  /// Publishes the map and the trajectory when changed, at their periods (own thread).
  void run_periodic();
  /// The IMU-rate odometry is read only while a client wants /fuse/pose or /tf, and the deskewed
  /// world scan only while one wants /fuse/scan: without one, fuse-state sends the odometry to one
  /// reader fewer and fuse-update neither builds nor sends the world scan (it publishes only to a
  /// matched reader). A stalled client does not count (foxglove::Server). Called by the periodic
  /// thread, without mutex_.
  void follow_demand();
  /// Makes `reader` of `topic` while `want`, drops it (waiting for a callback in flight, so
  /// mutex_ must not be held) when not; logs each change naming the `channels` that want it.
  template <class Msg, class Convert>
  void follow(std::unique_ptr<transport::Subscriber<Msg>>& reader, bool want, const char* topic, const char* channels,
              Convert convert) {
    if (want == (reader != nullptr)) return;
    if (!want) {
      reader.reset();
      logger("fuse-viz")->info("no client wants {}: stopped reading {}", channels, topic);
      return;
    }
    reader = std::make_unique<transport::Subscriber<Msg>>(participant_, topic, guarded(topic, convert), bad(topic));
    logger("fuse-viz")->info("a client wants {}: reading {}", channels, topic);
  }

  service::VizConfig config_;
  transport::Participant& participant_;
  foxglove::Server server_;

  mutable std::mutex mutex_;
  service::FoxgloveView view_;  // mutex_
  std::map<std::string, std::uint64_t> counters_;
  std::string last_error_;
  bool stopping_ = false;
  bool map_requested_ = false;         ///< a client subscribed to the map: send it now
  bool trajectory_requested_ = false;  ///< likewise the trajectory
  std::condition_variable wake_;
  std::thread periodic_;

  // Readers last: they call into everything above. odometry_ and world_scans_ are made and
  // dropped by the periodic thread only (follow_demand).
  std::unique_ptr<transport::Subscriber<fuse_msgs::StateEstimate>> odometry_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::StateEstimate>> corrected_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::WorldScan>> world_scans_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::MapChunk>> chunks_;
  std::unique_ptr<transport::Subscriber<fuse_msgs::Health>> health_;
};

}  // namespace fuse::viz

// A Foxglove WebSocket server (protocol foxglove.websocket.v1, docs/architecture.md "Live view"):
// the channels are fixed when it starts and advertised to every client on connection; a client
// subscribes to channels and receives each message published on them as a binary Message Data
// frame. Built on Boost.Beast; nothing of it shows in this header.
//
// Bounded per client: each client has a send queue of at most max_client_queue_bytes. When a
// message does not fit, the oldest queued messages of that client are dropped (counted) until it
// does; a slow client loses old samples, it never stalls publish() or grows a queue without bound.
// Bounded in age too: a live view wants the newest, so messages that waited longer than
// max_client_backlog_s are dropped (counted) rather than sent late in a burst. A client that has
// not taken a frame for that long is stalled (paused, or its network gone): it does not count as
// a subscriber (has_subscribers) until it reads again, so producers may skip the work of
// messages it would only lose, and they hear of it again through on_subscribe when it resumes.
// A latched channel keeps its last message and sends it to every new subscriber (a map, a
// static transform: whole to a client that connects late).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace fuse::foxglove {

/// The subprotocol this server speaks (and requires of its clients).
inline constexpr const char* kSubprotocol = "foxglove.websocket.v1";

struct ServerConfig {
  std::string address = "127.0.0.1";  ///< listen address; localhost unless configured otherwise
  std::uint16_t port = 8765;          ///< 0: any free port (port() tells which)
  std::size_t max_client_queue_bytes = 64u << 20;  ///< per client; older messages are dropped beyond it
  double max_client_backlog_s = 1.0;  ///< per client; queued messages older than this are dropped
  std::size_t max_clients = 16;       ///< connections beyond this are refused (counted)
  std::string name = "fuse-viz";      ///< serverInfo name
  /// Throws std::invalid_argument naming the first bad field.
  void validate() const;
};

/// One channel: its topic and how its messages are encoded (Advertise).
struct Channel {
  std::string topic;
  std::string encoding;         ///< message encoding, e.g. "json"
  std::string schema_name;      ///< e.g. "foxglove.PointCloud"
  std::string schema;           ///< the schema text
  std::string schema_encoding;  ///< e.g. "jsonschema"
  bool latched = false;         ///< the last message goes to every new subscriber
};
using ChannelId = std::uint32_t;  ///< 1 + the channel's index in the list given to the server

struct ServerStats {
  std::uint64_t clients = 0;            ///< connected now
  std::uint64_t connections = 0;        ///< accepted since start
  std::uint64_t refused = 0;            ///< handshakes refused (no foxglove subprotocol, too many clients)
  std::uint64_t messages_sent = 0;      ///< Message Data frames written
  std::uint64_t messages_dropped = 0;   ///< dropped from a slow client's queue (bytes or age bound)
  std::uint64_t bad_requests = 0;       ///< client messages that were not valid (answered with a status)
  std::uint64_t clients_stalled = 0;    ///< connected clients that have taken no frame for the backlog bound
  std::uint64_t stalls = 0;             ///< times a client became stalled, since start
};

class Server {
 public:
  /// Binds and starts serving on a thread of its own. Throws std::runtime_error naming the
  /// address when it cannot listen, std::invalid_argument on a bad config.
  Server(const ServerConfig& config, std::vector<Channel> channels);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  /// The port it listens on.
  std::uint16_t port() const;
  /// Sends `payload` on `channel` to every subscriber (any thread; returns at once).
  /// `log_time_ns` is the message's time. Throws std::out_of_range for an unknown channel.
  void publish(ChannelId channel, std::uint64_t log_time_ns, std::string payload);
  /// Whether any client that is not stalled is subscribed to `channel` now (an encoder may skip
  /// work otherwise).
  bool has_subscribers(ChannelId channel) const;
  /// Called (on the server's thread; keep it short) each time a client subscribes to a channel,
  /// and for each of its channels when a stalled client reads again: a producer that skips work
  /// while nobody listens can send a fresh message. Set it before clients connect.
  void on_subscribe(std::function<void(ChannelId)> callback);
  ServerStats stats() const;
  /// Closes every connection and stops the thread. Idempotent.
  void stop();

  struct Impl;  ///< the Beast side (server.cpp)

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace fuse::foxglove

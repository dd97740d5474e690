// Foxglove WebSocket server on Boost.Beast (fuse/foxglove/server.hpp). Everything that touches a
// connection runs on the server's one io thread; publish() only posts to it.
#include "fuse/foxglove/server.hpp"

#include <json/json.h>

#include <array>
#include <atomic>
#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <deque>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "fuse/core/logging.hpp"

namespace fuse::foxglove {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;

constexpr std::uint8_t kOpMessageData = 0x01;  // binary opcode of Message Data (spec, "Binary messages")
constexpr std::size_t kDataHeaderBytes = 1 + 4 + 8;  // opcode, subscription id, timestamp
constexpr std::size_t kMaxClientMessageBytes = 1u << 20;  // a subscribe list is small; more is refused
constexpr std::chrono::seconds kHandshakeTimeout{10};
constexpr int kStatusWarning = 1;
constexpr int kStatusError = 2;

std::string to_json(const Json::Value& value) {
  Json::StreamWriterBuilder builder;
  builder["indentation"] = "";
  return Json::writeString(builder, value);
}

/// Whether a Sec-WebSocket-Protocol list ("a, b") offers `wanted`.
bool offers(beast::string_view list, const std::string& wanted) {
  std::stringstream in{std::string(list)};
  std::string item;
  while (std::getline(in, item, ',')) {
    const auto first = item.find_first_not_of(" \t");
    const auto last = item.find_last_not_of(" \t");
    if (first != std::string::npos && item.substr(first, last - first + 1) == wanted) return true;
  }
  return false;
}

using Clock = std::chrono::steady_clock;

/// One queued frame: a text message, or a Message Data header with a payload shared by every client.
struct Frame {
  std::shared_ptr<const std::string> body;
  std::array<std::uint8_t, kDataHeaderBytes> header{};
  bool binary = false;
  ChannelId channel = 0;  ///< data frames: the channel it was published on
  bool latched = false;   ///< data frames: that channel is latched
  Clock::time_point queued{};
  std::size_t bytes() const { return body->size() + (binary ? kDataHeaderBytes : 0); }
};

Frame data_frame(const Channel& channel, ChannelId id, std::uint32_t subscription, std::uint64_t log_time_ns,
                 std::shared_ptr<const std::string> payload) {
  Frame f;
  f.binary = true;
  f.body = std::move(payload);
  f.channel = id;
  f.latched = channel.latched;
  f.header[0] = kOpMessageData;
  for (int i = 0; i < 4; ++i) f.header[1 + i] = static_cast<std::uint8_t>(subscription >> (8 * i));        // LE
  for (int i = 0; i < 8; ++i) f.header[5 + i] = static_cast<std::uint8_t>(log_time_ns >> (8 * i));        // LE
  return f;
}

Frame text_frame(const Json::Value& value) {
  Frame f;
  f.body = std::make_shared<const std::string>(to_json(value));
  return f;
}

}  // namespace

void ServerConfig::validate() const {
  boost::system::error_code ec;
  net::ip::make_address(address, ec);
  if (ec) throw std::invalid_argument("address: '" + address + "' is not an IP address");
  if (max_client_queue_bytes < 1024) throw std::invalid_argument("max_client_queue_bytes: at least 1024");
  if (!(max_client_backlog_s >= 0.01 && max_client_backlog_s <= 3600.0)) {
    throw std::invalid_argument("max_client_backlog_s: must be in [0.01, 3600] s");
  }
  if (max_clients < 1) throw std::invalid_argument("max_clients: at least 1");
  if (name.empty()) throw std::invalid_argument("name: empty");
}

class Session;

struct Server::Impl {
  ServerConfig config;
  std::vector<Channel> channels;
  net::io_context io;
  tcp::acceptor acceptor{io};
  std::thread thread;
  std::set<std::shared_ptr<Session>> sessions;          // io thread
  std::map<ChannelId, std::pair<std::uint64_t, std::shared_ptr<const std::string>>> latched;  // io thread
  std::vector<std::atomic<int>> subscribers;            // per channel index: clients not stalled
  std::string session_id;
  std::function<void(ChannelId)> subscribed;  // set before clients connect
  std::atomic<bool> stopped{false};
  std::atomic<std::uint64_t> clients{0}, connections{0}, refused{0}, sent{0}, dropped{0}, bad{0};
  std::atomic<std::uint64_t> stalled{0}, stalls{0};
  /// Published, not yet handed to the sessions: producers append, and only the first of a burst
  /// wakes the io thread (a pose and its transform, published together, cost one wake-up).
  struct Pending {
    ChannelId channel;
    std::uint64_t log_time_ns;
    std::shared_ptr<const std::string> body;
  };
  std::mutex pending_mutex;
  std::vector<Pending> pending;  // pending_mutex

  Impl(const ServerConfig& c, std::vector<Channel> ch)
      : config(c), channels(std::move(ch)), subscribers(channels.size()) {}
  void accept();
  Json::Value server_info() const;
  Json::Value advertise() const;
};

class Session : public std::enable_shared_from_this<Session> {
 public:
  Session(tcp::socket socket, Server::Impl& server) : ws_(std::move(socket)), server_(server) {}

  void start() {
    beast::get_lowest_layer(ws_).expires_after(kHandshakeTimeout);
    http::async_read(ws_.next_layer(), buffer_, request_,
                     [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_request(ec); });
  }

  /// Queues a frame; when it does not fit, drops this client's oldest queued data frames.
  void send(Frame frame) {
    if (closed_) return;
    const Clock::time_point now = Clock::now();
    frame.queued = now;
    review_backlog(now);
    const std::size_t limit = server_.config.max_client_queue_bytes;
    // Text frames (protocol) stay; the frame being written is out of the queue.
    auto it = queue_.begin();
    while (queued_bytes_ + frame.bytes() > limit) {
      while (it != queue_.end() && !it->binary) ++it;
      if (it == queue_.end()) break;
      queued_bytes_ -= it->bytes();
      it = queue_.erase(it);
      ++server_.dropped;
    }
    if (frame.binary && queued_bytes_ + frame.bytes() > limit) {
      ++server_.dropped;  // larger than what is left even with every older data frame gone
      return;
    }
    queued_bytes_ += frame.bytes();
    queue_.push_back(std::move(frame));
    if (!writing_) write_next();
  }

  /// The subscription id of `channel` for this client, if subscribed.
  const std::uint32_t* subscription_of(ChannelId channel) const {
    const auto it = by_channel_.find(channel);
    return it == by_channel_.end() ? nullptr : &it->second;
  }

  void close() {
    if (closed_) return;
    closed_ = true;
    if (!stalled_) {
      for (const auto& [sub, channel] : subscriptions_) --server_.subscribers[channel - 1];
    } else {
      --server_.stalled;
    }
    subscriptions_.clear();
    by_channel_.clear();
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
    beast::get_lowest_layer(ws_).socket().close(ignored);
    if (server_.sessions.erase(shared_from_this()) > 0) --server_.clients;
  }

 private:
  void refuse(http::status status, const std::string& why) {
    ++server_.refused;
    logger("foxglove")->warn("refused a connection: {}", why);
    auto response = std::make_shared<http::response<http::string_body>>(status, request_.version());
    response->set(http::field::content_type, "text/plain");
    response->body() = why + "\n";
    response->prepare_payload();
    http::async_write(ws_.next_layer(), *response,
                      [self = shared_from_this(), response](beast::error_code, std::size_t) {
                        beast::error_code ignored;
                        beast::get_lowest_layer(self->ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
                      });
  }

  void on_request(beast::error_code ec) {
    if (ec || server_.stopped) return;
    if (!websocket::is_upgrade(request_)) return refuse(http::status::bad_request, "not a WebSocket upgrade");
    if (!offers(request_[http::field::sec_websocket_protocol], kSubprotocol)) {
      return refuse(http::status::bad_request, std::string("the client does not offer the subprotocol ") + kSubprotocol);
    }
    if (server_.sessions.size() >= server_.config.max_clients) {
      return refuse(http::status::service_unavailable,
                    "too many clients (" + std::to_string(server_.config.max_clients) + ")");
    }
    beast::get_lowest_layer(ws_).expires_never();
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.set_option(websocket::stream_base::decorator([name = server_.config.name](websocket::response_type& res) {
      res.set(http::field::sec_websocket_protocol, kSubprotocol);
      res.set(http::field::server, name);
    }));
    ws_.read_message_max(kMaxClientMessageBytes);
    ws_.async_accept(request_, [self = shared_from_this()](beast::error_code e) { self->on_accept(e); });
  }

  void on_accept(beast::error_code ec) {
    if (ec || server_.stopped) return;
    server_.sessions.insert(shared_from_this());
    ++server_.clients;
    ++server_.connections;
    send(text_frame(server_.server_info()));
    send(text_frame(server_.advertise()));
    read_next();
  }

  void read_next() {
    ws_.async_read(incoming_, [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_read(ec); });
  }

  void on_read(beast::error_code ec) {
    if (ec) return close();
    if (!ws_.got_text()) {
      status(kStatusError, "binary client messages are not supported (no clientPublish capability)");
    } else {
      handle(beast::buffers_to_string(incoming_.data()));
    }
    incoming_.consume(incoming_.size());
    if (!closed_) read_next();
  }

  void status(int level, const std::string& message) {
    if (level >= kStatusError) ++server_.bad;
    Json::Value v;
    v["op"] = "status";
    v["level"] = level;
    v["message"] = message;
    send(text_frame(v));
  }

  void handle(const std::string& text) {
    Json::Value msg;
    std::string errors;
    const std::unique_ptr<Json::CharReader> reader(Json::CharReaderBuilder().newCharReader());
    if (!reader->parse(text.data(), text.data() + text.size(), &msg, &errors) || !msg.isObject() ||
        !msg["op"].isString()) {
      return status(kStatusError, "not a JSON object with an 'op': " + errors);
    }
    const std::string op = msg["op"].asString();
    if (op == "subscribe") return subscribe(msg["subscriptions"]);
    if (op == "unsubscribe") return unsubscribe(msg["subscriptionIds"]);
    status(kStatusWarning, "operation '" + op + "' is not supported by this server");
  }

  void subscribe(const Json::Value& list) {
    if (!list.isArray()) return status(kStatusError, "subscribe: 'subscriptions' is not an array");
    for (const Json::Value& s : list) {
      if (!s.isObject() || !s["id"].isUInt() || !s["channelId"].isUInt()) {
        status(kStatusError, "subscribe: each subscription needs an unsigned 'id' and 'channelId'");
        continue;
      }
      const std::uint32_t id = s["id"].asUInt();
      const ChannelId channel = s["channelId"].asUInt();
      if (channel < 1 || channel > server_.channels.size()) {
        status(kStatusError, "subscribe: no channel " + std::to_string(channel));
        continue;
      }
      if (subscriptions_.count(id) > 0) {
        status(kStatusError, "subscribe: subscription id " + std::to_string(id) + " is in use");
        continue;
      }
      if (by_channel_.count(channel) > 0) {
        status(kStatusError, "subscribe: already subscribed to channel " + std::to_string(channel));
        continue;
      }
      subscriptions_[id] = channel;
      by_channel_[channel] = id;
      if (!stalled_) ++server_.subscribers[channel - 1];
      if (server_.subscribed) server_.subscribed(channel);
      const auto last = server_.latched.find(channel);
      if (last != server_.latched.end()) {
        send(data_frame(server_.channels[channel - 1], channel, id, last->second.first, last->second.second));
      }
    }
  }

  void unsubscribe(const Json::Value& ids) {
    if (!ids.isArray()) return status(kStatusError, "unsubscribe: 'subscriptionIds' is not an array");
    for (const Json::Value& v : ids) {
      if (!v.isUInt() || subscriptions_.count(v.asUInt()) == 0) {
        status(kStatusWarning, "unsubscribe: no subscription " + v.toStyledString());
        continue;
      }
      const ChannelId channel = subscriptions_[v.asUInt()];
      subscriptions_.erase(v.asUInt());
      by_channel_.erase(channel);
      if (!stalled_) --server_.subscribers[channel - 1];
    }
  }

  /// Drops queued data frames that waited longer than the backlog bound, but the newest of each
  /// latched channel (a map or static transform that is not sent again until it changes), and
  /// marks the client stalled while the frame being written has waited that long.
  void review_backlog(Clock::time_point now) {
    const Clock::time_point oldest = now - std::chrono::duration_cast<Clock::duration>(
                                               std::chrono::duration<double>(server_.config.max_client_backlog_s));
    // Rebuild the queue only when its aged front holds a frame to drop: the frames kept (text, a
    // latched channel's) stay aged at the front, and a rebuild on every send would be wasted.
    bool droppable = false;
    for (auto it = queue_.begin(); it != queue_.end() && it->queued < oldest && !droppable; ++it) {
      droppable = it->binary && !it->latched;
    }
    if (droppable) {
      std::set<ChannelId> newer;  // latched channels whose newest queued frame was met
      std::deque<Frame> kept;
      for (auto i = queue_.size(); i-- > 0;) {  // newest first
        Frame& f = queue_[i];
        const bool newest_latched = f.latched && newer.insert(f.channel).second;
        if (!f.binary || newest_latched || f.queued >= oldest) {
          kept.push_front(std::move(f));
        } else {
          queued_bytes_ -= f.bytes();
          ++server_.dropped;
        }
      }
      queue_.swap(kept);
    }
    set_stalled(writing_ && write_started_ < oldest);
  }

  /// A stalled client does not count as a subscriber; when it reads again its channels are
  /// announced to the producers as if newly subscribed.
  void set_stalled(bool stalled) {
    if (stalled == stalled_) return;
    stalled_ = stalled;
    if (stalled) {
      ++server_.stalled;
      ++server_.stalls;
      for (const auto& [channel, sub] : by_channel_) --server_.subscribers[channel - 1];
      logger("foxglove")->warn("a client has taken no message for {} s: stalled, its old messages are dropped",
                               server_.config.max_client_backlog_s);
      return;
    }
    for (const auto& [channel, sub] : by_channel_) ++server_.subscribers[channel - 1];
    --server_.stalled;
    logger("foxglove")->info("a stalled client reads again");
    if (server_.subscribed) {
      for (const auto& [channel, sub] : by_channel_) server_.subscribed(channel);
    }
  }

  void write_next() {
    writing_ = true;
    write_started_ = Clock::now();
    in_flight_ = std::move(queue_.front());  // out of the queue: its buffers must not move while written
    queue_.pop_front();
    const Frame& f = in_flight_;
    ws_.binary(f.binary);
    auto done = [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_write(ec); };
    if (f.binary) {
      const std::array<net::const_buffer, 2> buffers{net::buffer(f.header), net::buffer(*f.body)};
      ws_.async_write(buffers, std::move(done));
    } else {
      ws_.async_write(net::buffer(*f.body), std::move(done));
    }
  }

  void on_write(beast::error_code ec) {
    writing_ = false;
    if (ec) return close();
    if (in_flight_.binary) ++server_.sent;
    queued_bytes_ -= in_flight_.bytes();
    in_flight_ = Frame{};
    if (closed_) return;
    review_backlog(Clock::now());
    if (!queue_.empty()) write_next();
  }

  websocket::stream<beast::tcp_stream> ws_;
  Server::Impl& server_;
  beast::flat_buffer buffer_;
  http::request<http::string_body> request_;
  beast::flat_buffer incoming_;
  std::deque<Frame> queue_;   // waiting, oldest first
  Frame in_flight_;           // being written while writing_
  std::size_t queued_bytes_ = 0;  // the queue's and the frame in flight's
  Clock::time_point write_started_{};
  bool writing_ = false;
  bool stalled_ = false;
  bool closed_ = false;
  std::map<std::uint32_t, ChannelId> subscriptions_;  // subscription id -> channel
  std::map<ChannelId, std::uint32_t> by_channel_;
};

void Server::Impl::accept() {
  acceptor.async_accept(net::make_strand(io), [this](beast::error_code ec, tcp::socket socket) {
    if (stopped || !acceptor.is_open()) return;
    if (!ec) std::make_shared<Session>(std::move(socket), *this)->start();
    accept();
  });
}

Json::Value Server::Impl::server_info() const {
  Json::Value v;
  v["op"] = "serverInfo";
  v["name"] = config.name;
  v["capabilities"] = Json::Value(Json::arrayValue);
  v["metadata"] = Json::Value(Json::objectValue);
  v["sessionId"] = session_id;
  return v;
}

Json::Value Server::Impl::advertise() const {
  Json::Value v;
  v["op"] = "advertise";
  v["channels"] = Json::Value(Json::arrayValue);
  for (std::size_t i = 0; i < channels.size(); ++i) {
    Json::Value c;
    c["id"] = static_cast<Json::UInt>(i + 1);
    c["topic"] = channels[i].topic;
    c["encoding"] = channels[i].encoding;
    c["schemaName"] = channels[i].schema_name;
    c["schema"] = channels[i].schema;
    c["schemaEncoding"] = channels[i].schema_encoding;
    v["channels"].append(c);
  }
  return v;
}

Server::Server(const ServerConfig& config, std::vector<Channel> channels)
    : impl_(std::make_unique<Impl>(config, std::move(channels))) {
  config.validate();
  Impl& s = *impl_;
  s.session_id = std::to_string(std::chrono::system_clock::now().time_since_epoch().count());
  const tcp::endpoint endpoint(net::ip::make_address(config.address), config.port);
  beast::error_code ec;
  s.acceptor.open(endpoint.protocol(), ec);
  if (!ec) s.acceptor.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) s.acceptor.bind(endpoint, ec);
  if (!ec) s.acceptor.listen(net::socket_base::max_listen_connections, ec);
  if (ec) {
    throw std::runtime_error("cannot listen on " + config.address + ":" + std::to_string(config.port) + ": " +
                             ec.message());
  }
  s.accept();
  s.thread = std::thread([&s] { s.io.run(); });
}

Server::~Server() { stop(); }

std::uint16_t Server::port() const { return impl_->acceptor.local_endpoint().port(); }

void Server::publish(ChannelId channel, std::uint64_t log_time_ns, std::string payload) {
  if (channel < 1 || channel > impl_->channels.size()) {
    throw std::out_of_range("publish: no channel " + std::to_string(channel));
  }
  if (impl_->stopped) return;
  auto body = std::make_shared<const std::string>(std::move(payload));
  {
    std::lock_guard<std::mutex> lock(impl_->pending_mutex);
    impl_->pending.push_back({channel, log_time_ns, std::move(body)});
    if (impl_->pending.size() > 1) return;  // a wake-up is already on its way
  }
  net::post(impl_->io, [impl = impl_.get()] {
    std::vector<Impl::Pending> batch;
    {
      std::lock_guard<std::mutex> lock(impl->pending_mutex);
      batch.swap(impl->pending);
    }
    // Copy: a failed write closes its session, which leaves the set.
    const std::vector<std::shared_ptr<Session>> sessions(impl->sessions.begin(), impl->sessions.end());
    for (const Impl::Pending& p : batch) {
      if (impl->channels[p.channel - 1].latched) impl->latched[p.channel] = {p.log_time_ns, p.body};
      for (const auto& session : sessions) {
        if (const std::uint32_t* sub = session->subscription_of(p.channel)) {
          session->send(data_frame(impl->channels[p.channel - 1], p.channel, *sub, p.log_time_ns, p.body));
        }
      }
    }
  });
}

void Server::on_subscribe(std::function<void(ChannelId)> callback) {
  net::post(impl_->io, [impl = impl_.get(), callback = std::move(callback)] { impl->subscribed = callback; });
}

bool Server::has_subscribers(ChannelId channel) const {
  return channel >= 1 && channel <= impl_->channels.size() && impl_->subscribers[channel - 1] > 0;
}

ServerStats Server::stats() const {
  const Impl& s = *impl_;
  return ServerStats{s.clients, s.connections, s.refused, s.sent, s.dropped, s.bad, s.stalled, s.stalls};
}

void Server::stop() {
  if (!impl_ || impl_->stopped.exchange(true)) return;
  Impl* s = impl_.get();
  net::post(s->io, [s] {
    beast::error_code ignored;
    s->acceptor.close(ignored);
    const std::vector<std::shared_ptr<Session>> sessions(s->sessions.begin(), s->sessions.end());
    for (const auto& session : sessions) session->close();
    s->io.stop();
  });
  if (s->thread.joinable()) s->thread.join();
}

}  // namespace fuse::foxglove

// The Foxglove layer without DDS: the encoders (base64 against RFC 4648's vectors, the JSON of
// each schema read back) and the WebSocket server against a client written here with Beast
// (handshake and subprotocol, advertise, subscribe, Message Data framing, latched channels,
// bad requests, and a client that stops reading: bounded, its oldest messages dropped, and
// stalled until it reads again).
#include <gtest/gtest.h>
#include <json/json.h>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <atomic>
#include <chrono>
#include <cstring>
#include <thread>

#include "fuse/foxglove/messages.hpp"
#include "fuse/foxglove/server.hpp"

namespace fuse::foxglove {
namespace {

namespace beast = boost::beast;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using namespace std::chrono_literals;

Json::Value parse(const std::string& text) {
  Json::Value v;
  std::string errors;
  const std::unique_ptr<Json::CharReader> reader(Json::CharReaderBuilder().newCharReader());
  EXPECT_TRUE(reader->parse(text.data(), text.data() + text.size(), &v, &errors)) << errors << ": " << text.substr(0, 200);
  return v;
}

std::vector<std::uint8_t> from_base64(const std::string& text) {
  static const std::string alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::vector<std::uint8_t> out;
  std::uint32_t acc = 0;
  int bits = 0;
  for (const char c : text) {
    if (c == '=') break;
    acc = (acc << 6) | static_cast<std::uint32_t>(alphabet.find(c));
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<std::uint8_t>(acc >> bits));
    }
  }
  return out;
}

TEST(FoxgloveMessages, Base64MatchesTheRfcVectors) {
  const auto b64 = [](const std::string& s) { return base64(reinterpret_cast<const std::uint8_t*>(s.data()), s.size()); };
  EXPECT_EQ(b64(""), "");
  EXPECT_EQ(b64("f"), "Zg==");
  EXPECT_EQ(b64("fo"), "Zm8=");
  EXPECT_EQ(b64("foo"), "Zm9v");
  EXPECT_EQ(b64("foob"), "Zm9vYg==");
  EXPECT_EQ(b64("fooba"), "Zm9vYmE=");
  EXPECT_EQ(b64("foobar"), "Zm9vYmFy");
}

TEST(FoxgloveMessages, EverySchemaIsJsonNamingItsFields) {
  for (const JsonSchema* s : {&pose_in_frame_schema(), &poses_in_frame_schema(), &frame_transforms_schema(),
                              &point_cloud_schema(), &health_schema()}) {
    const Json::Value v = parse(s->text);
    EXPECT_EQ(v["title"].asString(), s->name);
    EXPECT_EQ(v["type"].asString(), "object");
  }
  const Json::Value cloud = parse(point_cloud_schema().text);
  EXPECT_EQ(cloud["properties"]["data"]["contentEncoding"].asString(), "base64");
  for (const char* field : {"timestamp", "frame_id", "pose", "point_stride", "fields", "data"}) {
    EXPECT_TRUE(cloud["properties"].isMember(field)) << field;
  }
}

TEST(FoxgloveMessages, PointCloudCarriesTheFloatsItWasGiven) {
  const std::vector<float> xyz{1.5f, -2.25f, 3.0f, 1e-3f, 7.0f, -0.5f};
  const Json::Value v = parse(point_cloud_json(12.25, "world", xyz));
  EXPECT_EQ(v["timestamp"]["sec"].asUInt(), 12u);
  EXPECT_EQ(v["timestamp"]["nsec"].asUInt(), 250000000u);
  EXPECT_EQ(v["frame_id"].asString(), "world");
  EXPECT_EQ(v["point_stride"].asUInt(), 12u);
  ASSERT_EQ(v["fields"].size(), 3u);
  EXPECT_EQ(v["fields"][2]["name"].asString(), "z");
  EXPECT_EQ(v["fields"][2]["offset"].asUInt(), 8u);
  EXPECT_EQ(v["fields"][2]["type"].asInt(), 7);  // FLOAT32
  const std::vector<std::uint8_t> bytes = from_base64(v["data"].asString());
  ASSERT_EQ(bytes.size(), xyz.size() * 4);
  std::vector<float> back(xyz.size());
  std::memcpy(back.data(), bytes.data(), bytes.size());
  EXPECT_EQ(back, xyz);
  EXPECT_EQ(parse(point_cloud_json(1.0, "world", {}))["data"].asString(), "");
}

TEST(FoxgloveMessages, PosesAndTransformsKeepTheirValues) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translate(Eigen::Vector3d(1, 2, 3));
  T.rotate(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()));
  const Json::Value pose = parse(pose_in_frame_json(3.5, "world", T));
  EXPECT_DOUBLE_EQ(pose["pose"]["position"]["y"].asDouble(), 2.0);
  EXPECT_NEAR(pose["pose"]["orientation"]["z"].asDouble(), std::sin(0.25), 1e-12);
  const Json::Value tf = parse(frame_transforms_json({{3.5, "world", "imu", T}, {0.0, "imu", "lidar", T.inverse()}}));
  ASSERT_EQ(tf["transforms"].size(), 2u);
  EXPECT_EQ(tf["transforms"][0]["parent_frame_id"].asString(), "world");
  EXPECT_EQ(tf["transforms"][1]["child_frame_id"].asString(), "lidar");
  EXPECT_DOUBLE_EQ(tf["transforms"][0]["translation"]["z"].asDouble(), 3.0);
  const Json::Value poses = parse(poses_in_frame_json(4.0, "world", {T, T, T}));
  EXPECT_EQ(poses["poses"].size(), 3u);
  EXPECT_EQ(to_nanoseconds(-1.0), 0u);
  EXPECT_EQ(to_nanoseconds(1.000000001), 1000000001u);
}

/// A test client: Beast, synchronous, offering `subprotocol`.
class Client {
 public:
  Client(std::uint16_t port, const std::string& subprotocol = kSubprotocol) : ws_(io_) {
    tcp::resolver resolver(io_);
    net::connect(ws_.next_layer(), resolver.resolve("127.0.0.1", std::to_string(port)));
    ws_.set_option(websocket::stream_base::decorator([subprotocol](websocket::request_type& req) {
      req.set(beast::http::field::sec_websocket_protocol, subprotocol);
    }));
    ws_.handshake(response_, "127.0.0.1", "/");
  }
  const websocket::response_type& response() const { return response_; }
  /// The next message: text, or binary (as bytes in a string).
  std::string read(bool* binary = nullptr) {
    beast::flat_buffer buffer;
    ws_.read(buffer);
    if (binary) *binary = ws_.got_binary();
    return beast::buffers_to_string(buffer.data());
  }
  void send(const std::string& text) {
    ws_.text(true);
    ws_.write(net::buffer(text));
  }

 private:
  net::io_context io_;
  websocket::stream<tcp::socket> ws_;
  websocket::response_type response_;
};

std::uint32_t u32(const std::string& b, std::size_t at) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<std::uint8_t>(b[at + i]);
  return v;
}
std::uint64_t u64(const std::string& b, std::size_t at) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | static_cast<std::uint8_t>(b[at + i]);
  return v;
}

ServerConfig any_port() {
  ServerConfig c;
  c.port = 0;
  return c;
}

std::vector<Channel> two_channels() {
  return {{"/a", "json", "fuse.A", "{}", "jsonschema", false}, {"/latched", "json", "fuse.B", "{}", "jsonschema", true}};
}

template <class Pred>
bool wait_until(Pred pred, std::chrono::milliseconds timeout = 20000ms) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(5ms);
  }
  return true;
}

TEST(FoxgloveServer, AdvertisesSubscribesAndFramesMessageData) {
  Server server(any_port(), two_channels());
  server.publish(2, 5, "latched before anyone came");
  Client client(server.port());
  EXPECT_EQ(client.response()[beast::http::field::sec_websocket_protocol], kSubprotocol);
  const Json::Value info = parse(client.read());
  EXPECT_EQ(info["op"].asString(), "serverInfo");
  EXPECT_EQ(info["name"].asString(), "fuse-viz");
  const Json::Value adv = parse(client.read());
  ASSERT_EQ(adv["op"].asString(), "advertise");
  ASSERT_EQ(adv["channels"].size(), 2u);
  EXPECT_EQ(adv["channels"][0]["id"].asUInt(), 1u);
  EXPECT_EQ(adv["channels"][0]["topic"].asString(), "/a");
  EXPECT_EQ(adv["channels"][1]["schemaEncoding"].asString(), "jsonschema");

  client.send(R"({"op":"subscribe","subscriptions":[{"id":7,"channelId":1},{"id":9,"channelId":2}]})");
  // The latched channel's last message comes at once, under the new subscription's id.
  bool binary = false;
  std::string frame = client.read(&binary);
  ASSERT_TRUE(binary);
  ASSERT_EQ(frame.size(), 13u + 26u);
  EXPECT_EQ(static_cast<std::uint8_t>(frame[0]), 0x01);  // Message Data
  EXPECT_EQ(u32(frame, 1), 9u);
  EXPECT_EQ(u64(frame, 5), 5u);
  EXPECT_EQ(frame.substr(13), "latched before anyone came");
  ASSERT_TRUE(wait_until([&] { return server.has_subscribers(1); }));
  server.publish(1, 0x0102030405060708ull, "hello");
  frame = client.read(&binary);
  ASSERT_TRUE(binary);
  EXPECT_EQ(u32(frame, 1), 7u);
  EXPECT_EQ(u64(frame, 5), 0x0102030405060708ull);
  EXPECT_EQ(frame.substr(13), "hello");

  client.send(R"({"op":"unsubscribe","subscriptionIds":[7]})");
  ASSERT_TRUE(wait_until([&] { return !server.has_subscribers(1); }));
  EXPECT_TRUE(server.has_subscribers(2));
  EXPECT_EQ(server.stats().clients, 1u);
  EXPECT_THROW(server.publish(3, 0, "x"), std::out_of_range);
}

TEST(FoxgloveServer, ASubscriptionIsAnnouncedToTheProducer) {
  Server server(any_port(), two_channels());
  std::atomic<int> announced{0};
  server.on_subscribe([&](ChannelId channel) { announced = static_cast<int>(channel); });
  Client client(server.port());
  client.read();
  client.read();
  client.send(R"({"op":"subscribe","subscriptions":[{"id":3,"channelId":2}]})");
  EXPECT_TRUE(wait_until([&] { return announced == 2; }));
}

TEST(FoxgloveServer, BadRequestsGetAStatusAndTheConnectionStays) {
  Server server(any_port(), two_channels());
  Client client(server.port());
  client.read();
  client.read();
  for (const std::string& bad :
       {std::string("not json"), std::string(R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":99}]})"),
        std::string(R"({"op":"subscribe","subscriptions":"all"})"), std::string(R"({"no":"op"})")}) {
    client.send(bad);
    const Json::Value status = parse(client.read());
    EXPECT_EQ(status["op"].asString(), "status") << bad;
    EXPECT_EQ(status["level"].asInt(), 2) << bad;
    EXPECT_FALSE(status["message"].asString().empty());
  }
  client.send(R"({"op":"getParameters","parameterNames":[]})");
  EXPECT_EQ(parse(client.read())["level"].asInt(), 1);  // not supported: a warning
  EXPECT_EQ(server.stats().bad_requests, 4u);
  // Still served.
  client.send(R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":1}]})");
  ASSERT_TRUE(wait_until([&] { return server.has_subscribers(1); }));
  server.publish(1, 1, "after");
  EXPECT_EQ(client.read().substr(13), "after");
}

TEST(FoxgloveServer, AClientWithoutTheSubprotocolIsRefused) {
  Server server(any_port(), two_channels());
  EXPECT_THROW(Client(server.port(), "some.other.protocol"), boost::system::system_error);
  EXPECT_TRUE(wait_until([&] { return server.stats().refused == 1; }));
  EXPECT_EQ(server.stats().clients, 0u);
}

TEST(FoxgloveServer, ASlowClientLosesOldMessagesWithinItsBound) {
  ServerConfig config = any_port();
  config.max_client_queue_bytes = 2u << 20;
  Server server(config, two_channels());
  Client slow(server.port());
  slow.read();
  slow.read();
  slow.send(R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":1}]})");
  ASSERT_TRUE(wait_until([&] { return server.has_subscribers(1); }));
  // 200 MiB published to a client that reads nothing: at most the bound (and what the sockets
  // hold) waits for it; the rest is dropped and counted, and publish() never blocks.
  const std::string payload(1u << 20, 'x');
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < 200; ++i) server.publish(1, static_cast<std::uint64_t>(i), payload);
  EXPECT_LT(std::chrono::steady_clock::now() - start, 10s);
  // All but what fits in the 2 MiB bound and the socket buffers (a few MiB) is dropped.
  EXPECT_TRUE(wait_until([&] { return server.stats().messages_dropped >= 150; }))
      << server.stats().messages_dropped << " dropped, " << server.stats().messages_sent << " sent";
  // What it reads now is the newest messages, in order.
  bool binary = false;
  std::uint64_t previous = 0;
  for (int i = 0; i < 3; ++i) {
    const std::string frame = slow.read(&binary);
    ASSERT_TRUE(binary);
    EXPECT_GE(u64(frame, 5), previous);
    previous = u64(frame, 5);
  }
}

TEST(FoxgloveServer, AStalledClientCostsNothingUntilItReadsAgain) {
  ServerConfig config = any_port();
  config.max_client_backlog_s = 0.2;
  config.max_client_queue_bytes = std::size_t{1} << 30;  // only the age bound drops here
  Server server(config, two_channels());
  std::atomic<int> announced{0};
  server.on_subscribe([&](ChannelId channel) { announced += channel == 1 ? 1 : 0; });
  Client client(server.port());
  client.read();
  client.read();
  client.send(R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":1},{"id":2,"channelId":2}]})");
  ASSERT_TRUE(wait_until([&] { return server.has_subscribers(1) && server.has_subscribers(2); }));
  // The client stops reading: once the socket buffers are full and a frame has waited for the
  // backlog bound, it no longer counts as a subscriber.
  const std::string payload(1u << 20, 'x');
  std::uint64_t published = 0;
  ASSERT_TRUE(wait_until([&] {
    server.publish(1, ++published, payload);
    return !server.has_subscribers(1);
  }));
  EXPECT_FALSE(server.has_subscribers(2));
  EXPECT_EQ(server.stats().clients_stalled, 1u);
  EXPECT_EQ(server.stats().stalls, 1u);
  EXPECT_EQ(server.stats().clients, 1u);
  server.publish(2, 1000000, "the map while it was stalled");  // latched: kept however old
  std::this_thread::sleep_for(std::chrono::duration<double>(2 * config.max_client_backlog_s));  // let the queue age
  // It reads again: what waited beyond the bound is gone (counted), the latched frame is not,
  // and it counts as a subscriber again, announced to the producer as a new subscription.
  std::uint64_t received = 0;
  bool latched_seen = false;
  while (!latched_seen) {
    const std::string frame = client.read();
    if (u32(frame, 1) == 2) {
      EXPECT_EQ(frame.substr(13), "the map while it was stalled");
      latched_seen = true;
    } else {
      ++received;
    }
  }
  EXPECT_TRUE(wait_until([&] { return server.has_subscribers(1) && server.stats().clients_stalled == 0; }));
  EXPECT_GE(announced, 2);
  EXPECT_EQ(server.stats().messages_dropped, published - received);
  EXPECT_GT(server.stats().messages_dropped, 0u);
  // Fresh messages flow at once, with no backlog before them.
  server.publish(1, 2000000, "fresh");
  const std::string fresh = client.read();
  EXPECT_EQ(u64(fresh, 5), 2000000u);
}

TEST(FoxgloveServer, ConfigIsChecked) {
  ServerConfig c;
  c.address = "localhost.example";
  EXPECT_THROW(c.validate(), std::invalid_argument);
  c = ServerConfig{};
  c.max_client_queue_bytes = 10;
  EXPECT_THROW(c.validate(), std::invalid_argument);
  c = ServerConfig{};
  c.max_client_backlog_s = 0.0;
  EXPECT_THROW(c.validate(), std::invalid_argument);
  // A port in use: a clear error, not a crash.
  Server first(any_port(), two_channels());
  ServerConfig same = any_port();
  same.port = first.port();
  try {
    Server second(same, two_channels());
    FAIL() << "a second server bound the same port";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(std::to_string(first.port())), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace fuse::foxglove

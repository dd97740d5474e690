// Typed request/reply over two topics, "rpc/<service>/request" and "rpc/<service>/reply"
// (DESIGN §3). Every request and reply carries a header (client_id, request_id); a client keeps
// only replies with its own client_id. A client re-sends an unanswered request until its
// deadline (a reply can be lost while discovery is still matching the reply topic); the server
// remembers its last replies per client and answers a repeat without running the handler again.
// Request/Reply are generated types with `header`, and the replies with `error` and
// `error_message` (fuse_msgs::RpcStatus).
#pragma once

#include <chrono>
#include <condition_variable>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <thread>
#include <utility>

#include "fuse/transport/msg_traits.hpp"

namespace fuse::transport {

inline std::string request_topic(const std::string& service) { return "rpc/" + service + "/request"; }
inline std::string reply_topic(const std::string& service) { return "rpc/" + service + "/reply"; }

/// A random non-zero 64-bit id (client ids, service instance ids).
inline std::uint64_t random_id() {
  std::random_device rd;
  std::uint64_t id = 0;
  while (id == 0) id = (static_cast<std::uint64_t>(rd()) << 32) ^ rd();
  return id;
}

/// Where an RpcServer runs its handler.
enum class Dispatch {
  kWorker,  ///< on the server's own thread, behind a queue: for handlers that may take long
  /// on the transport's receive thread, as the request arrives: one thread hand-over less per
  /// call, for handlers that never block (a short lock and an answer, as fuse-state's query)
  kInline,
};

template <class Req, class Rep>
class RpcServer {
 public:
  /// Fills the reply for a request; the reply's error is RPC_OK unless the handler sets it.
  using Handler = std::function<void(const Req&, Rep&)>;

  RpcServer(Participant& participant, const std::string& service, Handler handler,
            Dispatch dispatch = Dispatch::kWorker)
      : handler_(std::move(handler)),
        dispatch_(dispatch),
        replies_(participant, reply_topic(service)),
        requests_(participant, request_topic(service), [this](const Req& r) { enqueue(r); }) {
    if (dispatch_ == Dispatch::kWorker) worker_ = std::thread([this] { run(); });
  }
  ~RpcServer() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    if (worker_.joinable()) worker_.join();
  }

  std::uint64_t handled() const { return handled_; }
  /// From now on, remember who sent each request (current_sender()): caller() names it while the
  /// handler runs. Off by default (a lookup per request).
  void track_callers() { track_callers_ = true; }
  /// The sender of the request being handled (handler thread only; empty unless tracked).
  const std::string& caller() const { return caller_; }
  std::uint64_t malformed() const { return requests_.malformed(); }

 private:
  void enqueue(const Req& r) {
    std::string sender = track_callers_ ? current_sender() : std::string();
    if (dispatch_ == Dispatch::kInline) {
      handle(r, std::move(sender));
      return;
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      queue_.emplace_back(r, std::move(sender));
    }
    cv_.notify_one();
  }

  void run() {
    for (;;) {
      std::pair<Req, std::string> item;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        cv_.wait(lock, [this] { return stop_ || !queue_.empty(); });
        if (stop_) return;
        item = std::move(queue_.front());
        queue_.pop_front();
      }
      handle(item.first, std::move(item.second));
    }
  }

  void handle(const Req& req, std::string sender) {
    std::lock_guard<std::mutex> lock(handle_mutex_);
    caller_ = std::move(sender);
    const auto client = req.header().client_id();
    auto cached = last_.find(client);
    if (cached != last_.end() && cached->second.header().request_id() == req.header().request_id()) {
      replies_.publish(cached->second);  // a repeat: answer again, do not run the handler twice
      return;
    }
    Rep rep;
    rep.error(fuse_msgs::RPC_OK);
    try {
      handler_(req, rep);
    } catch (const std::exception& e) {
      rep.error(fuse_msgs::RPC_INTERNAL_ERROR);
      rep.error_message(std::string(e.what()).substr(0, 255));
    }
    rep.header(req.header());
    ++handled_;
    replies_.publish(rep);
    if (last_.size() > kMaxClients) last_.clear();
    last_[client] = rep;
  }

  static constexpr std::size_t kMaxClients = 256;
  Handler handler_;
  const Dispatch dispatch_;
  Publisher<Rep> replies_;
  std::mutex mutex_;  ///< guards queue_ and stop_
  std::condition_variable cv_;
  std::deque<std::pair<Req, std::string>> queue_;  ///< requests and their senders
  bool stop_ = false;
  std::atomic<bool> track_callers_{false};
  std::string caller_;       ///< handle_mutex_
  std::mutex handle_mutex_;  ///< one request at a time; guards last_ and caller_
  std::map<std::uint64_t, Rep> last_;
  std::atomic<std::uint64_t> handled_{0};
  Subscriber<Req> requests_;
  std::thread worker_;
};

template <class Req, class Rep>
class RpcClient {
 public:
  struct Result {
    fuse_msgs::RpcStatus status = fuse_msgs::RPC_UNAVAILABLE;
    std::string message;
    Rep reply;
    bool ok() const { return status == fuse_msgs::RPC_OK; }
  };

  RpcClient(Participant& participant, const std::string& service)
      : client_id_(random_id()),
        requests_(participant, request_topic(service)),
        replies_(participant, reply_topic(service), [this](const Rep& r) { receive(r); }) {}

  /// True once both topics are matched with a server.
  bool connected() const { return requests_.matched() > 0 && replies_.matched() > 0; }
  bool wait_for_server(std::chrono::milliseconds timeout) const {
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (!connected()) {
      if (std::chrono::steady_clock::now() >= end) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
  }

  /// Sends the request and waits for its reply until the deadline (RPC_UNAVAILABLE then).
  /// Thread-safe.
  Result call(Req request, std::chrono::milliseconds deadline,
              std::chrono::milliseconds resend_every = std::chrono::milliseconds(100)) {
    const auto end = std::chrono::steady_clock::now() + deadline;
    Result result;
    std::unique_lock<std::mutex> lock(mutex_);
    const std::uint64_t id = ++next_request_;
    request.header().client_id(client_id_);
    request.header().request_id(id);
    pending_[id].reset();
    lock.unlock();
    while (!connected() && std::chrono::steady_clock::now() < end) {
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    lock.lock();
    while (!pending_[id]) {
      const auto now = std::chrono::steady_clock::now();
      if (now >= end) break;
      lock.unlock();
      requests_.publish(request);
      lock.lock();
      cv_.wait_until(lock, std::min(end, now + resend_every), [&] { return pending_[id].has_value(); });
    }
    if (pending_[id]) {
      result.reply = std::move(*pending_[id]);
      result.status = result.reply.error();
      result.message = result.reply.error_message();
    } else {
      result.message = "no reply before the deadline";
    }
    pending_.erase(id);
    return result;
  }

  std::uint64_t client_id() const { return client_id_; }

 private:
  void receive(const Rep& r) {
    if (r.header().client_id() != client_id_) return;  // another client's reply
    {
      std::lock_guard<std::mutex> lock(mutex_);
      auto it = pending_.find(r.header().request_id());
      if (it == pending_.end() || it->second) return;  // late, or a duplicate
      it->second = r;
    }
    cv_.notify_all();
  }

  const std::uint64_t client_id_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::uint64_t next_request_ = 0;
  std::map<std::uint64_t, std::optional<Rep>> pending_;
  Publisher<Req> requests_;
  Subscriber<Rep> replies_;
};

}  // namespace fuse::transport

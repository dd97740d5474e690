// Client: the public query API over the transport's typed request/reply (PIMPL keeps every DDS
// and generated type out of the installed header).
#include "fuse/query/client.hpp"

#include <algorithm>
#include <chrono>
#include <exception>
#include <functional>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>

#include "fuse/core/scheduling.hpp"
#include "fuse/transport/rpc.hpp"
#include "fuse/transport/typed.hpp"
#include "time_check.hpp"
#include "wire_conversion.hpp"

namespace fuse::query {

namespace {
using QueryRpc = transport::RpcClient<fuse_msgs::QueryRequest, fuse_msgs::QueryReply>;

/// The options, unless they are out of range (std::invalid_argument then).
const ClientOptions& checked(const ClientOptions& o) {
  if (o.vendor != "fastdds" && o.vendor != "cyclonedds") {
    throw std::invalid_argument("vendor '" + o.vendor + "' is not fastdds or cyclonedds");
  }
  if (o.domain_id < 0 || o.domain_id > 101) {
    throw std::invalid_argument("domain_id " + std::to_string(o.domain_id) + " is outside 0..101");
  }
  if (o.deadline_ms <= 0) throw std::invalid_argument("deadline_ms must be positive");
  // The transport config's bounds (transport: section).
  if (o.max_participants < 4 || o.max_participants > 120) {
    throw std::invalid_argument("max_participants must be in [4, 120]");
  }
  if (o.socket_buffer_bytes < (64u << 10) || o.socket_buffer_bytes > (256u << 20)) {
    throw std::invalid_argument("socket_buffer_bytes must be in [64 KiB, 256 MiB]");
  }
  if (!valid_scheduler_slice(o.scheduler_slice_us)) {
    throw std::invalid_argument("scheduler_slice_us must be 0 or in [" + std::to_string(kMinSchedulerSliceUs) + ", " +
                                std::to_string(kMaxSchedulerSliceUs) + "]");
  }
  return o;
}

transport::TransportConfig transport_config(const ClientOptions& o) {
  transport::TransportConfig c;
  c.vendor = o.vendor;
  c.domain_id = o.domain_id;
  c.loopback_only = o.loopback_only;
  c.max_participants = o.max_participants;
  c.shared_memory = o.shared_memory;
  c.socket_buffer_bytes = o.socket_buffer_bytes;
  c.system_name = o.system_name;
  c.security.enabled = o.security;
  c.security.keystore = o.security_keystore;
  c.security.identity = o.security_identity;
  c.security.private_key = o.security_private_key;
  c.interfaces = o.interfaces;
  c.peers = o.peers;
  return c;
}

/// The participant and the RPC endpoints, made on a thread of their own that requests the
/// configured slice first: the transport threads they start inherit it, the caller's thread
/// keeps its attributes.
struct Endpoints {
  std::unique_ptr<transport::Participant> participant;
  std::unique_ptr<QueryRpc> rpc;  // destroyed before the participant (declared after it)
};

Endpoints make_endpoints(const ClientOptions& o) {
  Endpoints e;
  std::exception_ptr error;
  std::thread([&] {
    try {
      if (o.scheduler_slice_us > 0) request_scheduler_slice(o.scheduler_slice_us);  // not applied: default slice
      e.participant = transport::make_participant(transport_config(o), o.participant_name);
      e.rpc = std::make_unique<QueryRpc>(*e.participant, transport::services::kQuery);
    } catch (...) {
      error = std::current_exception();
    }
  }).join();
  if (error) std::rethrow_exception(error);
  return e;
}
}  // namespace

class Client::Impl {
 public:
  explicit Impl(const ClientOptions& options) : options_(checked(options)), endpoints_(make_endpoints(options_)) {}

  Result call(fuse_msgs::QueryRequest request) {
    const auto r = endpoints_.rpc->call(std::move(request), std::chrono::milliseconds(options_.deadline_ms));
    return to_result(r.status, r.message, r.reply);
  }

  bool wait_for_server(int timeout_ms) const {
    return endpoints_.rpc->wait_for_server(std::chrono::milliseconds(std::max(timeout_ms, 0)));
  }

  const ClientOptions& options() const { return options_; }

  void subscribe(std::function<void(const Result&)> callback) {
    std::lock_guard<std::mutex> lock(stream_mutex_);
    callback_ = std::move(callback);
    ensure_subscribed();
  }

  Result newest() {
    std::lock_guard<std::mutex> lock(stream_mutex_);
    ensure_subscribed();
    if (!newest_) return Result{Error::not_ready, "no streamed estimate has arrived yet", {}};
    return *newest_;
  }

 private:
  /// Lock held. The reader of state/odometry, made once.
  void ensure_subscribed() {
    if (odometry_) return;
    odometry_ = std::make_unique<transport::Subscriber<fuse_msgs::StateEstimate>>(
        *endpoints_.participant, transport::topics::kOdometry, [this](const fuse_msgs::StateEstimate& m) {
          const Result r = to_result(m);
          std::function<void(const Result&)> callback;
          {
            std::lock_guard<std::mutex> lock(stream_mutex_);
            newest_ = r;
            callback = callback_;
          }
          if (callback) callback(r);  // outside the lock: it may call newest()
        });
  }

  ClientOptions options_;
  Endpoints endpoints_;
  std::mutex stream_mutex_;  ///< guards the three below
  std::function<void(const Result&)> callback_;
  std::optional<Result> newest_;
  /// Declared last: destroyed first, so no callback runs into the members above as they go.
  std::unique_ptr<transport::Subscriber<fuse_msgs::StateEstimate>> odometry_;
};

Client::Client(const ClientOptions& options) : impl_(std::make_unique<Impl>(options)) {}
Client::~Client() = default;
Client::Client(Client&&) noexcept = default;
Client& Client::operator=(Client&&) noexcept = default;

Result Client::at(double t, Clock clock) {
  if (std::string why = check_query_time(t); !why.empty()) return Result{Error::bad_request, why, {}};
  fuse_msgs::QueryRequest request;
  request.t(t);
  request.latest(false);
  switch (clock) {
    case Clock::sensor: request.clock(fuse_msgs::CLOCK_SENSOR); break;
    case Clock::host_realtime: request.clock(fuse_msgs::CLOCK_HOST_REALTIME); break;
    case Clock::host_monotonic: request.clock(fuse_msgs::CLOCK_HOST_MONOTONIC); break;
    default: return Result{Error::bad_request, "unknown clock", {}};
  }
  return impl_->call(request);
}

void Client::subscribe(std::function<void(const Result&)> callback) { impl_->subscribe(std::move(callback)); }

Result Client::newest() { return impl_->newest(); }

Result Client::latest() {
  fuse_msgs::QueryRequest request;
  request.latest(true);
  return impl_->call(request);
}

bool Client::wait_for_server(int timeout_ms) { return impl_->wait_for_server(timeout_ms); }

const ClientOptions& Client::options() const { return impl_->options(); }

const char* to_string(Error error) {
  switch (error) {
    case Error::ok: return "ok";
    case Error::bad_request: return "bad_request";
    case Error::not_ready: return "not_ready";
    case Error::unavailable: return "unavailable";
    case Error::internal: return "internal";
    case Error::out_of_range: return "out_of_range";
    case Error::not_tracking: return "not_tracking";
  }
  return "unknown";
}

const char* to_string(Status status) {
  switch (status) {
    case Status::not_initialised: return "not_initialised";
    case Status::interpolated: return "interpolated";
    case Status::propagated: return "propagated";
    case Status::too_old: return "too_old";
    case Status::in_future: return "in_future";
    case Status::relocalizing: return "relocalizing";
    case Status::lost: return "lost";
  }
  return "unknown";
}

}  // namespace fuse::query

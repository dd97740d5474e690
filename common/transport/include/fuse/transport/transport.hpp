// Transport (DESIGN §3): a vendor-neutral participant that moves serialised samples (XCDR1 CDR
// with the 4-byte encapsulation header) over DDS topics. Fast DDS is the default backend;
// Cyclone DDS is chosen by config. Nothing above this layer sees a DDS type: the typed
// Publisher/Subscriber (typed.hpp) and the request/reply template (rpc.hpp) are built on it.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "fuse/core/config.hpp"
#include "fuse/transport/security.hpp"

namespace fuse::transport {

struct TransportConfig {
  std::string vendor = "fastdds";  ///< fastdds | cyclonedds
  int domain_id = 0;               ///< 0..101 (higher ids collide with ephemeral ports)
  /// Discovery by unicast on 127.0.0.1 only (loopback has no multicast): Fast DDS initial peers
  /// with maxInitialPeersRange = max_participants; Cyclone with multicast off on `lo` and
  /// MaxAutoParticipantIndex = max_participants.
  bool loopback_only = true;
  /// Across computers (loopback_only false): the IPv4 addresses of this computer's interfaces
  /// DDS may use (empty: all), and the unicast discovery peers, the addresses of the system's
  /// computers (empty: multicast discovery). Both vendors probe max_participants ports on each
  /// peer, and this computer's own interfaces are peers too, so one list serves every computer.
  std::vector<std::string> interfaces;
  std::vector<std::string> peers;
  int max_participants = 32;
  std::size_t socket_buffer_bytes = 4u << 20;  ///< send/receive buffers (~1 MiB clouds need 4 MiB)
  bool shared_memory = false;  ///< Fast DDS shared-memory transport / data-sharing (off: UDP only)
  /// The system this process belongs to: every topic and RPC of it lives in the DDS partition of
  /// this name, so two systems on one domain never see each other, while topic names (and so
  /// recordings and their replay) stay the same. Empty: the default partition. 1–64 letters,
  /// digits, '_', '-', '.' (no partition wildcards).
  std::string system_name;
  SecurityConfig security;  ///< DDS Security (security.hpp); off by default
  void load(ConfigNode& node);
};

enum class Reliability { kBestEffort, kReliable };
enum class Durability { kVolatile, kTransientLocal };

struct TopicQos {
  Reliability reliability = Reliability::kReliable;
  Durability durability = Durability::kVolatile;
  int depth = 10;  ///< KEEP_LAST depth (per instance for keyed topics)
};

/// What a backend needs to know about a type to register it: its IDL name (e.g.
/// "fuse_msgs::ImuSample"), whether it is keyed (the key is then the first member, a uint64),
/// and its largest serialised size.
struct TypeSupport {
  std::string name;
  bool keyed = false;
  std::size_t max_serialized_size = 0;
};

using Bytes = std::vector<std::uint8_t>;
/// Called on a backend thread with one serialised sample (encapsulation header included).
using RawHandler = std::function<void(const std::uint8_t* data, std::size_t size)>;

class RawWriter {
 public:
  virtual ~RawWriter() = default;
  /// Publishes one serialised sample; false when the backend refused it (logged by the backend).
  virtual bool write(const Bytes& sample) = 0;
  virtual std::size_t matched_readers() const = 0;
  /// Blocks until every matched reliable reader has acknowledged every sample written, or the
  /// timeout passed; true when all were acknowledged. A publisher about to exit calls it so that
  /// what it wrote is not lost with its history (a late-joined reader still catching up).
  virtual bool wait_for_acknowledgments(std::chrono::milliseconds timeout) = 0;
};

class RawReader {
 public:
  virtual ~RawReader() = default;
  virtual std::size_t matched_writers() const = 0;
};

class Participant {
 public:
  virtual ~Participant() = default;
  virtual std::unique_ptr<RawWriter> create_writer(const std::string& topic, const TypeSupport& type,
                                                   const TopicQos& qos) = 0;
  /// `handler` is called for every received sample until the reader is destroyed.
  virtual std::unique_ptr<RawReader> create_reader(const std::string& topic, const TypeSupport& type,
                                                   const TopicQos& qos, RawHandler handler) = 0;
  virtual std::string vendor() const = 0;
};

/// Who sent the sample whose handler is running on this thread: the sending participant's name
/// and, where its vendor tells it (Fast DDS, security on), the subject of its certificate
/// ("CN=fuse-map-ctl (fuse-map-ctl)"). Empty outside a handler or when unknown. Resolved on
/// demand: a handler that never asks costs nothing.
std::string current_sender();

namespace detail {
/// Set by a backend around a handler call: resolves the sender of the sample in hand.
class SenderLookup {
 public:
  virtual ~SenderLookup() = default;
  virtual std::string sender() const = 0;
};
/// Makes `lookup` the current thread's sender for its lifetime.
class SenderScope {
 public:
  explicit SenderScope(const SenderLookup* lookup);
  ~SenderScope();
  SenderScope(const SenderScope&) = delete;
  SenderScope& operator=(const SenderScope&) = delete;

 private:
  const SenderLookup* previous_;
};
}  // namespace detail

/// Creates a participant of the configured vendor; throws std::runtime_error naming what failed.
/// `name` identifies the process in discovery (e.g. "fuse-state").
std::unique_ptr<Participant> make_participant(const TransportConfig& config, const std::string& name);

}  // namespace fuse::transport

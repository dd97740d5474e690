// THE table of topic QoS (DESIGN §3). Reliable + transient-local where a late or restarted
// subscriber needs what was published before it joined; best-effort where only the newest
// sample matters; depths sized to what a subscriber may need to catch up on.
#include "fuse/transport/qos.hpp"

#include <map>
#include <stdexcept>

#include "fuse/transport/rpc.hpp"

namespace fuse::transport {

namespace {

constexpr TopicQos qos(Reliability r, Durability d, int depth) { return TopicQos{r, d, depth}; }
constexpr auto kReliable = Reliability::kReliable;
constexpr auto kBestEffort = Reliability::kBestEffort;
constexpr auto kVolatile = Durability::kVolatile;
constexpr auto kTransientLocal = Durability::kTransientLocal;

std::map<std::string, TopicQos> make_table() {
  std::map<std::string, TopicQos> t;
  // IMU at up to ~400 Hz: 2000 samples (~5 s) stay with the writer, so a restarted fuse-state
  // re-propagates from the buffered IMU instead of waiting for new data.
  t[topics::kImu] = qos(kReliable, kTransientLocal, 2000);
  // Scans are large (up to MBs). Transient-local with 3 s of them at 10 Hz: scans published
  // while a restarted fuse-ingest is still being discovered arrive once it is (a restarted
  // fuse-update skips the ones fuse-state has already corrected).
  t[topics::kLidarScan] = qos(kReliable, kTransientLocal, 30);
  // High-rate odometry: a lost sample is superseded by the next one; no retransmissions.
  t[topics::kOdometry] = qos(kBestEffort, kVolatile, 10);
  // The latest corrected state: a late joiner gets it at once.
  t[topics::kCorrected] = qos(kReliable, kTransientLocal, 1);
  // fuse-update's answers, one per scan: a (re)starting fuse-state picks the newest posterior
  // from them. Scans skipped while fuse-state was down are answered too, so the depth covers
  // 5 s of them at 10 Hz and the last real posterior is still held.
  t[topics::kCorrection] = qos(kReliable, kTransientLocal, 50);
  // Every accepted scan's points must reach the map server (it journals them); 100 in flight.
  t[topics::kObservation] = qos(kReliable, kVolatile, 100);
  // For viewers only: the newest deskewed scan matters, a lost one is superseded by the next.
  t[topics::kWorldScan] = qos(kBestEffort, kVolatile, 2);
  // Keyed by chunk: depth 1 per instance, so a late-joining replica gets the latest of every chunk.
  t[topics::kMapChunk] = qos(kReliable, kTransientLocal, 1);
  // Latest map status (epoch, mode, acked sequence) for late joiners.
  t[topics::kMapStatus] = qos(kReliable, kTransientLocal, 1);
  // Health of every writer (one per service instance) for a late monitor. Keyless, so a reader's
  // depth is shared by all writers: 16 keeps two heartbeats arriving together from dropping one.
  t[topics::kHealth] = qos(kReliable, kTransientLocal, 16);
  // Request/reply: volatile (a late server must not answer stale requests), 32 deep so a burst
  // of calls from several clients is not dropped. The query and history calls are best-effort:
  // the RPC layer already re-sends an unanswered request and the server answers a repeat from
  // its cache, so DDS reliability only added heartbeats and acknowledgements, more packets and
  // thread wake-ups per call (query p99 during a real-time replay 0.96 -> 0.76 ms on Fast DDS,
  // docs/performance.md). Map control stays reliable: rare commands, no latency to win, and a
  // lost one would wait for the re-send.
  for (const char* service : {services::kQuery, services::kHistory}) {
    t[request_topic(service)] = qos(kBestEffort, kVolatile, 32);
    t[reply_topic(service)] = qos(kBestEffort, kVolatile, 32);
  }
  for (const char* service : {services::kMapControl, services::kSetPose}) {
    t[request_topic(service)] = qos(kReliable, kVolatile, 32);
    t[reply_topic(service)] = qos(kReliable, kVolatile, 32);
  }
  return t;
}

}  // namespace

TopicQos with_depth(TopicQos qos, int depth) {
  constexpr int kMaxDepth = 1000000;
  if (depth < 1 || depth > kMaxDepth) {
    throw std::invalid_argument("transport: history depth " + std::to_string(depth) + " outside 1.." +
                                std::to_string(kMaxDepth));
  }
  qos.depth = depth;
  return qos;
}

const TopicQos& topic_qos(const std::string& topic) {
  static const std::map<std::string, TopicQos> table = make_table();
  auto it = table.find(topic);
  if (it == table.end()) throw std::invalid_argument("transport: no QoS for unknown topic '" + topic + "'");
  return it->second;
}

}  // namespace fuse::transport

// Fast DDS 2.9 backend: moves opaque CDR samples (encapsulation header included) under the IDL
// type name, so that the bytes Fast CDR wrote are the bytes on the wire.
//
// - Type: one TopicDataType per IDL type ("fuse_msgs::X"). serialize/deserialize are copies of
//   the sample bytes; the largest size comes from the generated type (TypeSupport), no type
//   object or type information is sent (Cyclone rejects fastddsgen's). A keyed type (our keys
//   are a uint64 first member) hashes its key as the spec says for keys of at most 16 bytes:
//   the key serialised big-endian and zero-padded (MD5 of it only when Fast DDS forces it).
// - Memory: DYNAMIC_REUSABLE payloads. Samples go up to several MB at most but are usually
//   small; preallocating max size x depth would reserve GBs.
// - Discovery: UDPv4 only (the builtin transports are off; shared memory only when configured),
//   unicast to initial peers on 127.0.0.1 because loopback has no multicast. Fast DDS probes
//   the ports of participant ids 0..maxInitialPeersRange-1 there, so maxInitialPeersRange is
//   the configured number of participants (the default 4 misses the fifth process).
//   loopback_only whitelists 127.0.0.1, so nothing leaves the machine. Across computers
//   (loopback_only false) the configured interfaces are whitelisted and the configured peers,
//   with this computer's own interface addresses, are the initial peers (unicast discovery;
//   Fast DDS also announces on multicast where a link has it).
// - Sockets: send/receive buffers of config.socket_buffer_bytes (4 MiB): with the default
//   buffers a 1 MiB cloud takes ~12 ms on loopback (fragments are dropped and repaired), ~1 ms
//   with 4 MiB.
// - Reliable writers heartbeat every 100 ms (default 3 s) so a lost fragment is repaired fast,
//   and send one before the first write after a reader matched: Cyclone DDS readers drop data
//   until they have seen a heartbeat and then treat everything it lists as old history, and
//   Fast DDS would only heartbeat once there is data (so the first sample to a Cyclone reader
//   got lost). assert_liveliness() is the public way to send a heartbeat on demand; it needs
//   manual-by-topic liveliness, whose lease stays infinite so liveliness never lapses.
// - Shared memory: segments of crashed processes stay in /dev/shm; `fastdds shm clean` removes
//   them when shared memory is enabled (best effort, never an error).
// - Receive: the reader's listener takes every available sample and hands the bytes to the
//   RawHandler, one call at a time per reader. Local writers deliver in the writer's thread
//   (Fast DDS intra-process delivery), remote ones in the receive thread. RTPS pads payloads to
//   4 bytes; the padding is removed when the encapsulation options declare it (Fast DDS does
//   not declare it, so the typed layer tolerates up to 3 trailing bytes).
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#include <fastrtps/utils/md5.h>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <stdexcept>

#include "backends.hpp"
#include "fuse/core/logging.hpp"

namespace fuse::transport::detail {

namespace dds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;
using eprosima::fastrtps::types::ReturnCode_t;

namespace {

std::shared_ptr<spdlog::logger> log() { return fuse::logger("transport"); }

/// Opaque samples of one IDL type. The sample object Fast DDS passes around is a Bytes.
class OpaqueType : public dds::TopicDataType {
 public:
  explicit OpaqueType(const TypeSupport& type) {
    setName(type.name.c_str());
    const std::size_t max = std::max<std::size_t>(type.max_serialized_size, 4);
    m_typeSize = static_cast<uint32_t>(std::min<std::size_t>(max + 3, UINT32_MAX - 3) & ~std::size_t{3});
    m_isGetKeyDefined = type.keyed;
    auto_fill_type_object(false);
    auto_fill_type_information(false);
  }

  bool serialize(void* data, rtps::SerializedPayload_t* payload) override {
    const auto& sample = *static_cast<const Bytes*>(data);
    if (sample.size() < 4 || sample.size() > payload->max_size) return false;
    std::memcpy(payload->data, sample.data(), sample.size());
    payload->length = static_cast<uint32_t>(sample.size());
    payload->encapsulation = (sample[1] & 1u) ? CDR_LE : CDR_BE;
    return true;
  }

  bool deserialize(rtps::SerializedPayload_t* payload, void* data) override {
    auto& sample = *static_cast<Bytes*>(data);
    sample.assign(payload->data, payload->data + payload->length);
    return true;
  }

  std::function<uint32_t()> getSerializedSizeProvider(void* data) override {
    return [data] { return static_cast<uint32_t>(static_cast<const Bytes*>(data)->size()); };
  }

  void* createData() override { return new Bytes(); }
  void deleteData(void* data) override { delete static_cast<Bytes*>(data); }

  bool getKey(void* data, rtps::InstanceHandle_t* handle, bool force_md5) override {
    if (!m_isGetKeyDefined) return false;
    const auto& sample = *static_cast<const Bytes*>(data);
    std::array<std::uint8_t, 16> hash;
    key_hash_from_sample(sample.data(), sample.size(), hash);  // a short sample hashes as key 0
    if (force_md5) {
      ::MD5 md5;
      md5.init();
      md5.update(hash.data(), 8);  // the serialised key: 8 big-endian bytes
      md5.finalize();
      std::memcpy(hash.data(), md5.digest, 16);
    }
    for (std::size_t i = 0; i < 16; ++i) handle->value[i] = hash[i];
    return true;
  }
};

/// The names of the participants this one discovered, by GUID prefix: for current_sender(). With
/// security on, the subject of the certificate the participant authenticated with comes first
/// (its identity token's dds.cert.sn), then the name it gives itself.
class ParticipantNames : public dds::DomainParticipantListener {
 public:
  void on_participant_discovery(dds::DomainParticipant*, rtps::ParticipantDiscoveryInfo&& info) override {
    using Status = rtps::ParticipantDiscoveryInfo::DISCOVERY_STATUS;
    std::lock_guard<std::mutex> lock(mutex_);
    if (info.status == Status::REMOVED_PARTICIPANT || info.status == Status::DROPPED_PARTICIPANT) {
      names_.erase(info.info.m_guid.guidPrefix);
      return;
    }
    std::string name = info.info.m_participantName.to_string();
    for (const auto& property : info.info.identity_token_.properties()) {
      if (property.name() == "dds.cert.sn" && !property.value().empty()) name = property.value() + " (" + name + ")";
    }
    names_[info.info.m_guid.guidPrefix] = name;
  }
  std::string name(const rtps::GuidPrefix_t& prefix) const {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = names_.find(prefix);
    return it == names_.end() ? std::string() : it->second;
  }
  void add_self(const rtps::GuidPrefix_t& prefix, const std::string& name) {
    std::lock_guard<std::mutex> lock(mutex_);
    names_[prefix] = name;
  }

 private:
  mutable std::mutex mutex_;
  std::map<rtps::GuidPrefix_t, std::string> names_;
};

/// DDS Security with the builtin plugins: PKI-DH authentication, access control by the signed
/// governance and permissions, AES-GCM-GMAC cryptography (what governance asks for: ENCRYPT).
void add_security_properties(dds::DomainParticipantQos& pqos, const SecurityFiles& f) {
  auto& props = pqos.properties().properties();
  const auto add = [&props](const std::string& key, const std::string& value) { props.emplace_back(key, value); };
  add("dds.sec.auth.plugin", "builtin.PKI-DH");
  add("dds.sec.auth.builtin.PKI-DH.identity_ca", "file://" + f.identity_ca);
  add("dds.sec.auth.builtin.PKI-DH.identity_certificate", "file://" + f.certificate);
  add("dds.sec.auth.builtin.PKI-DH.private_key", "file://" + f.private_key);
  add("dds.sec.access.plugin", "builtin.Access-Permissions");
  add("dds.sec.access.builtin.Access-Permissions.permissions_ca", "file://" + f.permissions_ca);
  add("dds.sec.access.builtin.Access-Permissions.governance", "file://" + f.governance);
  add("dds.sec.access.builtin.Access-Permissions.permissions", "file://" + f.permissions);
  add("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
}

/// The DDS participant with its one publisher and subscriber, and the topics in use. Shared by
/// the Participant and every writer/reader it made, so their destruction order does not matter.
class Context {
 public:
  Context(const TransportConfig& config, const std::string& name)
      : identity_(config.security.enabled ? security_identity(config.security, name) : "") {
    if (config.shared_memory) {
      // Remove segments left in /dev/shm by crashed processes; absent tool or failure is fine.
      if (std::system("fastdds shm clean >/dev/null 2>&1") != 0) {
        log()->debug("fastdds shm clean did not run; stale shared-memory segments may remain");
      }
    }
    dds::DomainParticipantQos pqos;
    pqos.name(name);
    pqos.transport().use_builtin_transports = false;
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    udp->sendBufferSize = static_cast<uint32_t>(config.socket_buffer_bytes);
    udp->receiveBufferSize = static_cast<uint32_t>(config.socket_buffer_bytes);
    udp->maxInitialPeersRange = static_cast<uint32_t>(config.max_participants);
    if (config.loopback_only) udp->interfaceWhiteList.emplace_back("127.0.0.1");
    for (const std::string& a : config.interfaces) udp->interfaceWhiteList.emplace_back(a);
    pqos.transport().user_transports.push_back(udp);
    if (config.shared_memory) {
      auto shm = std::make_shared<eprosima::fastdds::rtps::SharedMemTransportDescriptor>();
      shm->maxInitialPeersRange = static_cast<uint32_t>(config.max_participants);
      pqos.transport().user_transports.push_back(shm);
    }
    // Port 0: every participant id in range.
    for (const std::string& address : discovery_peers(config)) {
      rtps::Locator_t peer;
      rtps::IPLocator::setIPv4(peer, address);
      pqos.wire_protocol().builtin.initialPeersList.push_back(peer);
    }
    // A participant that joins late (a restarted service, a short-lived CLI) is answered at the
    // others' next periodic announcement: 0.5 s instead of the default 3 s bounds that wait, and
    // a 5 s lease lets the others forget a killed process sooner (loopback traffic is tiny).
    auto& discovery = pqos.wire_protocol().builtin.discovery_config;
    discovery.leaseDuration_announcementperiod = eprosima::fastrtps::Duration_t(0, 500000000);
    discovery.leaseDuration = eprosima::fastrtps::Duration_t(5, 0);

    if (config.security.enabled) add_security_properties(pqos, security_files(config.security, name));

    auto* factory = dds::DomainParticipantFactory::get_instance();
    participant_ = factory->create_participant(config.domain_id, pqos, &names_, dds::StatusMask::none());
    if (participant_ == nullptr) {
      throw std::runtime_error("transport: Fast DDS could not create a participant on domain " +
                               std::to_string(config.domain_id) +
                               (config.security.enabled ? " (security on: a certificate, key or signed document was refused; "
                                                          "see the log above)"
                                                        : ""));
    }
    names_.add_self(participant_->guid().guidPrefix, name);
    // transport.system_name: every endpoint in that partition only, so that two systems on one
    // domain never match each other's topics (empty: the default partition).
    dds::PublisherQos publisher_qos = dds::PUBLISHER_QOS_DEFAULT;
    dds::SubscriberQos subscriber_qos = dds::SUBSCRIBER_QOS_DEFAULT;
    if (!config.system_name.empty()) {
      publisher_qos.partition().push_back(config.system_name.c_str());
      subscriber_qos.partition().push_back(config.system_name.c_str());
    }
    publisher_ = participant_->create_publisher(publisher_qos);
    subscriber_ = participant_->create_subscriber(subscriber_qos);
    if (publisher_ == nullptr || subscriber_ == nullptr) {
      participant_->delete_contained_entities();
      factory->delete_participant(participant_);
      throw std::runtime_error("transport: Fast DDS could not create a publisher/subscriber");
    }
  }

  ~Context() {
    participant_->set_listener(nullptr);
    participant_->delete_contained_entities();
    dds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }
  /// The name of the participant with this GUID prefix (empty: unknown).
  std::string participant_name(const rtps::GuidPrefix_t& prefix) const { return names_.name(prefix); }

  dds::Publisher* publisher() const { return publisher_; }
  /// Why an endpoint may have been refused: the grant of this process's security identity.
  std::string refusal_hint(const std::string& what) const { return security_refusal_hint(identity_, what); }
  dds::Subscriber* subscriber() const { return subscriber_; }

  /// The topic (created on first use, with its type registered); release_topic() when done.
  dds::Topic* acquire_topic(const std::string& topic, const TypeSupport& type) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = topics_.find(topic);
    if (it != topics_.end()) {
      if (it->second.topic->get_type_name() != type.name) {
        throw std::runtime_error("transport: topic '" + topic + "' already has type " +
                                 it->second.topic->get_type_name() + ", not " + type.name);
      }
      ++it->second.users;
      return it->second.topic;
    }
    if (participant_->find_type(type.name).empty()) {
      dds::TypeSupport support(new OpaqueType(type));
      if (participant_->register_type(support) != ReturnCode_t::RETCODE_OK) {
        throw std::runtime_error("transport: Fast DDS could not register type " + type.name);
      }
    }
    dds::Topic* t = participant_->create_topic(topic, type.name, dds::TOPIC_QOS_DEFAULT);
    if (t == nullptr) throw std::runtime_error("transport: Fast DDS could not create topic '" + topic + "'" + refusal_hint("use"));
    topics_[topic] = TopicUse{t, 1};
    return t;
  }

  void release_topic(const std::string& topic) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = topics_.find(topic);
    if (it == topics_.end() || --it->second.users > 0) return;
    participant_->delete_topic(it->second.topic);
    topics_.erase(it);
  }

 private:
  struct TopicUse {
    dds::Topic* topic;
    int users;
  };
  std::string identity_;  ///< the security identity (empty: security off)
  ParticipantNames names_;  ///< before participant_: its listener
  dds::DomainParticipant* participant_ = nullptr;
  dds::Publisher* publisher_ = nullptr;
  dds::Subscriber* subscriber_ = nullptr;
  std::mutex mutex_;
  std::map<std::string, TopicUse> topics_;
};

template <class Qos>
void apply_common_qos(Qos& q, const TypeSupport& type, const TopicQos& qos) {
  q.reliability().kind = qos.reliability == Reliability::kReliable ? dds::RELIABLE_RELIABILITY_QOS
                                                                   : dds::BEST_EFFORT_RELIABILITY_QOS;
  q.durability().kind = qos.durability == Durability::kTransientLocal ? dds::TRANSIENT_LOCAL_DURABILITY_QOS
                                                                      : dds::VOLATILE_DURABILITY_QOS;
  q.history().kind = dds::KEEP_LAST_HISTORY_QOS;
  q.history().depth = qos.depth;
  auto& limits = q.resource_limits();
  limits.max_samples_per_instance = qos.depth;
  if (type.keyed) {
    // 0, not LENGTH_UNLIMITED: the history pool is sized depth x max_instances, 0 = no limit.
    limits.max_instances = 0;
    limits.max_samples = 0;
  } else {
    limits.max_instances = 1;
    limits.max_samples = qos.depth;
  }
  limits.allocated_samples = std::min(qos.depth, 16);
  q.endpoint().history_memory_policy = rtps::DYNAMIC_REUSABLE_MEMORY_MODE;
  q.data_sharing().off();  // needs plain (fixed-size) types; ours are opaque byte strings
}

class FastddsWriter : public RawWriter {
 public:
  FastddsWriter(std::shared_ptr<Context> context, const std::string& topic, const TypeSupport& type,
                const TopicQos& qos)
      : context_(std::move(context)), topic_(topic), reliable_(qos.reliability == Reliability::kReliable) {
    dds::Topic* t = context_->acquire_topic(topic, type);
    dds::DataWriterQos q = context_->publisher()->get_default_datawriter_qos();
    apply_common_qos(q, type, qos);
    q.reliable_writer_qos().times.heartbeatPeriod = eprosima::fastrtps::Duration_t(0, 100000000);
    // Manual-by-topic liveliness (lease infinite, so it never lapses) is what lets
    // assert_liveliness() send a heartbeat on demand; see write().
    if (reliable_) q.liveliness().kind = dds::MANUAL_BY_TOPIC_LIVELINESS_QOS;
    writer_ = context_->publisher()->create_datawriter(t, q);
    if (writer_ == nullptr) {
      context_->release_topic(topic);
      throw std::runtime_error("transport: Fast DDS could not create a writer on '" + topic + "'" +
                               context_->refusal_hint("publish"));
    }
  }
  ~FastddsWriter() override {
    context_->publisher()->delete_datawriter(writer_);
    context_->release_topic(topic_);
  }

  bool write(const Bytes& sample) override {
    // A Cyclone DDS reader ignores a reliable writer's data until it has seen a heartbeat, and
    // then takes everything up to the heartbeat's last sequence number as old history: the
    // first sample after matching would be lost, because Fast DDS heartbeats only once it has
    // data. So a heartbeat goes out first whenever a reader matched since the last write.
    if (reliable_) {
      dds::PublicationMatchedStatus status;
      writer_->get_publication_matched_status(status);
      if (status.total_count > heartbeat_matches_.exchange(status.total_count)) writer_->assert_liveliness();
    }
    if (writer_->write(const_cast<Bytes*>(&sample))) return true;
    log()->warn("Fast DDS refused a sample of {} bytes on '{}'", sample.size(), topic_);
    return false;
  }

  std::size_t matched_readers() const override {
    dds::PublicationMatchedStatus status;
    writer_->get_publication_matched_status(status);
    return static_cast<std::size_t>(std::max(status.current_count, 0));
  }

  bool wait_for_acknowledgments(std::chrono::milliseconds timeout) override {
    const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(timeout).count();
    const eprosima::fastrtps::Duration_t max_wait(static_cast<int32_t>(ns / 1000000000),
                                                  static_cast<uint32_t>(ns % 1000000000));
    return writer_->wait_for_acknowledgments(max_wait) == ReturnCode_t::RETCODE_OK;
  }

 private:
  std::shared_ptr<Context> context_;
  std::string topic_;
  bool reliable_;
  std::atomic<int32_t> heartbeat_matches_{0};  ///< matches (total_count) already heartbeaten
  dds::DataWriter* writer_ = nullptr;
};

class FastddsReader : public RawReader, public dds::DataReaderListener {
  /// The sender of the sample in hand, looked up only when asked.
  class Sender : public SenderLookup {
   public:
    Sender(const Context& context, const rtps::GuidPrefix_t& prefix) : context_(context), prefix_(prefix) {}
    std::string sender() const override { return context_.participant_name(prefix_); }

   private:
    const Context& context_;
    rtps::GuidPrefix_t prefix_;
  };

 public:
  FastddsReader(std::shared_ptr<Context> context, const std::string& topic, const TypeSupport& type,
                const TopicQos& qos, RawHandler handler)
      : context_(std::move(context)), topic_(topic), handler_(std::move(handler)) {
    dds::Topic* t = context_->acquire_topic(topic, type);
    dds::DataReaderQos q = context_->subscriber()->get_default_datareader_qos();
    apply_common_qos(q, type, qos);
    reader_ = context_->subscriber()->create_datareader(t, q, this, dds::StatusMask::data_available());
    if (reader_ == nullptr) {
      context_->release_topic(topic);
      throw std::runtime_error("transport: Fast DDS could not create a reader on '" + topic + "'" +
                               context_->refusal_hint("subscribe to"));
    }
  }
  ~FastddsReader() override {
    {
      std::lock_guard<std::mutex> lock(take_mutex_);
      closed_ = true;  // a callback already past the DDS layer returns without calling the handler
    }
    reader_->set_listener(nullptr);
    context_->subscriber()->delete_datareader(reader_);
    context_->release_topic(topic_);
  }

  std::size_t matched_writers() const override {
    dds::SubscriptionMatchedStatus status;
    reader_->get_subscription_matched_status(status);
    return static_cast<std::size_t>(std::max(status.current_count, 0));
  }

  void on_data_available(dds::DataReader* reader) override {
    std::lock_guard<std::mutex> lock(take_mutex_);
    if (closed_) return;
    dds::SampleInfo info;
    while (reader->take_next_sample(&sample_, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;  // dispose/unregister notifications carry no sample
      const Sender sender(*context_, info.sample_identity.writer_guid().guidPrefix);
      const SenderScope scope(&sender);
      try {
        handler_(sample_.data(), unpadded_size(sample_.data(), sample_.size()));
      } catch (const std::exception& e) {
        log()->error("handler of '{}' threw: {}", topic_, e.what());
      }
    }
  }

 private:
  std::shared_ptr<Context> context_;
  std::string topic_;
  RawHandler handler_;
  std::mutex take_mutex_;
  bool closed_ = false;
  Bytes sample_;  ///< reused receive buffer (take_mutex_)
  dds::DataReader* reader_ = nullptr;
};

class FastddsParticipant : public Participant {
 public:
  FastddsParticipant(const TransportConfig& config, const std::string& name)
      : context_(std::make_shared<Context>(config, name)) {}

  std::unique_ptr<RawWriter> create_writer(const std::string& topic, const TypeSupport& type,
                                           const TopicQos& qos) override {
    return std::make_unique<FastddsWriter>(context_, topic, type, qos);
  }
  std::unique_ptr<RawReader> create_reader(const std::string& topic, const TypeSupport& type, const TopicQos& qos,
                                           RawHandler handler) override {
    return std::make_unique<FastddsReader>(context_, topic, type, qos, std::move(handler));
  }
  std::string vendor() const override { return "fastdds"; }

 private:
  std::shared_ptr<Context> context_;
};

}  // namespace

std::unique_ptr<Participant> make_fastdds_participant(const TransportConfig& config, const std::string& name) {
  return std::make_unique<FastddsParticipant>(config, name);
}

}  // namespace fuse::transport::detail

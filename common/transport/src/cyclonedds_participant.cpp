// Cyclone DDS 0.10 backend (C API): the same opaque CDR samples as the Fast DDS backend, under
// the same IDL type names, so either vendor talks to the other.
//
// - Type: a custom sertype/serdata pair whose sample is the serialised bytes themselves (what
//   ROS 2's Cyclone layer does). The other route, idlc descriptors plus dds_writecdr, needs the
//   writer's sertype to build a serdata, and 0.10 has no public call that returns it; with our
//   own sertype Cyclone never (de)serialises anything, and malformed bytes reach the typed
//   Subscriber, which counts them, exactly as with Fast DDS. Keys are computed here: keyed types
//   have a uint64 first member, hashed as the spec says for keys of at most 16 bytes (the key
//   big-endian, zero-padded), read honouring the encapsulation's endianness.
// - No type information in discovery (Fast DDS sends none either): matching is by type name.
// - Data representation XCDR1 on every reader and writer, the encoding Fast CDR writes.
// - Domain: configured with dds_create_domain(domain_id, xml), once per process and domain id
//   (Cyclone runs one instance per domain and process; every participant of the process shares
//   it). Multicast off and unicast peers on 127.0.0.1, because loopback has no multicast; the
//   `lo` interface when loopback_only (across computers: the configured interfaces and peers, and
//   multicast only when no peers are configured); ParticipantIndex auto with MaxAutoParticipantIndex =
//   max_participants, so every process of a test gets its own port and is probed by the others
//   (and Fast DDS participants, whose ports follow the same formula, are reached too).
// - Sockets: buffers of config.socket_buffer_bytes requested (not required: a smaller kernel
//   limit degrades large samples instead of refusing to start). On loopback, messages of up to
//   65000 bytes with 62000-byte fragments (default 14720/1344): a third of the latency for 1 MiB.
// - Transient-local writers keep `depth` samples for late joiners (durability_service depth;
//   Cyclone's default is 1), and do not dispose their instances when deleted.
// - Receive: a data_available listener takes every sample (dds_takecdr) and hands the bytes to
//   the RawHandler, one call at a time per reader, without the padding the encapsulation
//   options declare (RTPS pads payloads to 4 bytes).
#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>
#include <dds/ddsi/ddsi_sertype.h>
#include <dds/ddsi/q_radmin.h>
#include <dds/ddsrt/md5.h>

#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <new>
#include <stdexcept>

#include "backends.hpp"
#include "fuse/core/logging.hpp"

namespace fuse::transport::detail {

namespace {

std::shared_ptr<spdlog::logger> log() { return fuse::logger("transport"); }

std::string error_text(dds_return_t rc) { return std::string(dds_strretcode(rc)); }

// ---- sertype / serdata: samples are their own serialised bytes --------------------------------

struct OpaqueSertype {
  ddsi_sertype c;  // first member: Cyclone passes &c around
  bool keyed = false;
};

struct OpaqueSerdata {
  ddsi_serdata c;  // first member
  std::uint32_t size = 0;             ///< serialised size, encapsulation header included
  std::uint8_t* data = nullptr;       ///< size rounded up to 4 (zero padding: to_ser may read it)
  std::array<std::uint8_t, 16> key{};  ///< key hash (all zero for keyless types)
};

const OpaqueSertype* sertype_of(const ddsi_sertype* t) { return reinterpret_cast<const OpaqueSertype*>(t); }
OpaqueSerdata* serdata_of(ddsi_serdata* d) { return reinterpret_cast<OpaqueSerdata*>(d); }
const OpaqueSerdata* serdata_of(const ddsi_serdata* d) { return reinterpret_cast<const OpaqueSerdata*>(d); }

std::uint32_t fnv1a(const std::uint8_t* p, std::size_t n) {
  std::uint32_t h = 2166136261u;
  for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 16777619u;
  return h;
}

/// A serdata of `size` bytes (uninitialised, zero padding), key and hash still to be set.
OpaqueSerdata* new_serdata(const ddsi_sertype* type, ddsi_serdata_kind kind, std::size_t size) {
  auto* d = new OpaqueSerdata();
  ddsi_serdata_init(&d->c, type, kind);
  d->size = static_cast<std::uint32_t>(size);
  const std::size_t padded = (size + 3) & ~std::size_t{3};
  d->data = static_cast<std::uint8_t*>(std::calloc(padded == 0 ? 4 : padded, 1));
  if (d->data == nullptr) {
    delete d;
    throw std::bad_alloc();
  }
  return d;
}

/// Sets key and hash from the bytes (a keyed type's key is its first member, a uint64).
ddsi_serdata* finish_serdata(OpaqueSerdata* d) {
  if (sertype_of(d->c.type)->keyed) key_hash_from_sample(d->data, d->size, d->key);
  d->c.hash = fnv1a(d->key.data(), d->key.size()) ^ d->c.type->serdata_basehash;
  return &d->c;
}

/// Key-only serdata (header + the key as big-endian CDR) with the given key hash.
OpaqueSerdata* new_key_serdata(const ddsi_sertype* type, const std::array<std::uint8_t, 16>& key) {
  OpaqueSerdata* d = new_serdata(type, SDK_KEY, 4 + 8);
  d->data[0] = 0x00;  // CDR_BE
  d->data[1] = 0x00;
  std::memcpy(d->data + 4, key.data(), 8);
  d->key = key;
  return d;
}

bool sd_eqkey(const ddsi_serdata* a, const ddsi_serdata* b) { return serdata_of(a)->key == serdata_of(b)->key; }

std::uint32_t sd_get_size(const ddsi_serdata* d) { return serdata_of(d)->size; }

ddsi_serdata* sd_from_ser(const ddsi_sertype* type, ddsi_serdata_kind kind, const nn_rdata* fragchain,
                          std::size_t size) {
  OpaqueSerdata* d = new_serdata(type, kind, size);
  // Fragments are byte ranges [min, maxp1) of the sample, in order, possibly overlapping.
  std::uint32_t filled = 0;
  for (const nn_rdata* f = fragchain; f != nullptr; f = f->nextfrag) {
    if (f->min > filled || f->maxp1 <= filled) continue;
    const std::uint32_t end = std::min<std::uint32_t>(f->maxp1, d->size);
    const unsigned char* payload = NN_RMSG_PAYLOADOFF(f->rmsg, NN_RDATA_PAYLOAD_OFF(f));
    std::memcpy(d->data + filled, payload + (filled - f->min), end - filled);
    filled = end;
  }
  return finish_serdata(d);
}

ddsi_serdata* sd_from_ser_iov(const ddsi_sertype* type, ddsi_serdata_kind kind, ddsrt_msg_iovlen_t niov,
                              const ddsrt_iovec_t* iov, std::size_t size) {
  OpaqueSerdata* d = new_serdata(type, kind, size);
  std::size_t off = 0;
  for (ddsrt_msg_iovlen_t i = 0; i < niov && off < size; ++i) {
    const std::size_t n = std::min<std::size_t>(iov[i].iov_len, size - off);
    std::memcpy(d->data + off, iov[i].iov_base, n);
    off += n;
  }
  return finish_serdata(d);
}

ddsi_serdata* sd_from_keyhash(const ddsi_sertype* type, const ddsi_keyhash* keyhash) {
  std::array<std::uint8_t, 16> key{};
  if (sertype_of(type)->keyed) std::memcpy(key.data(), keyhash->value, 8);  // plain, not MD5: 8 <= 16 bytes
  OpaqueSerdata* d = new_key_serdata(type, key);
  d->c.hash = fnv1a(d->key.data(), d->key.size()) ^ type->serdata_basehash;
  return &d->c;
}

/// The application sample of this sertype is a Bytes holding the serialised sample.
ddsi_serdata* sd_from_sample(const ddsi_sertype* type, ddsi_serdata_kind kind, const void* sample) {
  const auto& bytes = *static_cast<const Bytes*>(sample);
  OpaqueSerdata* d = new_serdata(type, kind, bytes.size());
  if (!bytes.empty()) std::memcpy(d->data, bytes.data(), bytes.size());
  return finish_serdata(d);
}

void sd_to_ser(const ddsi_serdata* d, std::size_t off, std::size_t sz, void* buf) {
  std::memcpy(buf, serdata_of(d)->data + off, sz);
}

ddsi_serdata* sd_to_ser_ref(const ddsi_serdata* d, std::size_t off, std::size_t sz, ddsrt_iovec_t* ref) {
  ref->iov_base = serdata_of(d)->data + off;
  ref->iov_len = static_cast<ddsrt_iov_len_t>(sz);
  return ddsi_serdata_ref(d);
}

void sd_to_ser_unref(ddsi_serdata* d, const ddsrt_iovec_t*) { ddsi_serdata_unref(d); }

bool sd_to_sample(const ddsi_serdata* d, void* sample, void**, void*) {
  const OpaqueSerdata* s = serdata_of(d);
  static_cast<Bytes*>(sample)->assign(s->data, s->data + s->size);
  return true;
}

// Untyped serdata (instance administration across topics): just the key.
ddsi_serdata* sd_to_untyped(const ddsi_serdata* d) {
  const OpaqueSerdata* s = serdata_of(d);
  OpaqueSerdata* u = new_key_serdata(d->type, s->key);
  u->c.hash = d->hash;
  u->c.type = nullptr;  // untyped
  return &u->c;
}

bool sd_untyped_to_sample(const ddsi_sertype*, const ddsi_serdata* d, void* sample, void**, void*) {
  return sd_to_sample(d, sample, nullptr, nullptr);
}

void sd_free(ddsi_serdata* d) {
  OpaqueSerdata* s = serdata_of(d);
  std::free(s->data);
  delete s;
}

std::size_t sd_print(const ddsi_sertype*, const ddsi_serdata* d, char* buf, std::size_t size) {
  const int n = std::snprintf(buf, size, "(%u bytes of CDR)", serdata_of(d)->size);
  return n < 0 ? 0 : static_cast<std::size_t>(n);
}

void sd_get_keyhash(const ddsi_serdata* d, ddsi_keyhash* buf, bool force_md5) {
  const OpaqueSerdata* s = serdata_of(d);
  if (!force_md5) {
    std::memcpy(buf->value, s->key.data(), 16);
    return;
  }
  ddsrt_md5_state_t md5;
  ddsrt_md5_init(&md5);
  ddsrt_md5_append(&md5, s->key.data(), 8);  // the serialised key: 8 big-endian bytes
  ddsrt_md5_finish(&md5, buf->value);
}

ddsi_serdata_ops make_serdata_ops() {
  ddsi_serdata_ops ops;
  std::memset(&ops, 0, sizeof ops);  // also clears the shared-memory (iceoryx) entries: unused
  ops.eqkey = sd_eqkey;
  ops.get_size = sd_get_size;
  ops.from_ser = sd_from_ser;
  ops.from_ser_iov = sd_from_ser_iov;
  ops.from_keyhash = sd_from_keyhash;
  ops.from_sample = sd_from_sample;
  ops.to_ser = sd_to_ser;
  ops.to_ser_ref = sd_to_ser_ref;
  ops.to_ser_unref = sd_to_ser_unref;
  ops.to_sample = sd_to_sample;
  ops.to_untyped = sd_to_untyped;
  ops.untyped_to_sample = sd_untyped_to_sample;
  ops.free = sd_free;
  ops.print = sd_print;
  ops.get_keyhash = sd_get_keyhash;
  return ops;
}
const ddsi_serdata_ops kSerdataOps = make_serdata_ops();

// Sample arrays (only used by dds_read/dds_take with loans, which we do not call): Bytes objects.
void st_free(ddsi_sertype* t) {
  ddsi_sertype_fini(t);
  delete reinterpret_cast<OpaqueSertype*>(t);
}

void st_zero_samples(const ddsi_sertype*, void* samples, std::size_t count) {
  auto* s = static_cast<Bytes*>(samples);
  for (std::size_t i = 0; i < count; ++i) s[i].clear();
}

void st_realloc_samples(void** ptrs, const ddsi_sertype*, void* old, std::size_t oldcount, std::size_t count) {
  auto* fresh = static_cast<Bytes*>(::operator new(std::max<std::size_t>(count, 1) * sizeof(Bytes)));
  auto* previous = static_cast<Bytes*>(old);
  for (std::size_t i = 0; i < count; ++i) {
    if (i < oldcount && previous != nullptr) {
      new (&fresh[i]) Bytes(std::move(previous[i]));
    } else {
      new (&fresh[i]) Bytes();
    }
  }
  if (previous != nullptr) {
    for (std::size_t i = 0; i < oldcount; ++i) previous[i].~Bytes();
    ::operator delete(previous);
  }
  if (ptrs != nullptr) {
    for (std::size_t i = 0; i < count; ++i) ptrs[i] = &fresh[i];
  }
}

void st_free_samples(const ddsi_sertype*, void** ptrs, std::size_t count, dds_free_op_t op) {
  if (count == 0 || ptrs == nullptr || ptrs[0] == nullptr) return;
  if (op & DDS_FREE_ALL_BIT) {
    auto* base = static_cast<Bytes*>(ptrs[0]);
    for (std::size_t i = 0; i < count; ++i) base[i].~Bytes();
    ::operator delete(base);
  } else if (op & DDS_FREE_CONTENTS_BIT) {
    for (std::size_t i = 0; i < count; ++i) Bytes().swap(*static_cast<Bytes*>(ptrs[i]));
  }
}

bool st_equal(const ddsi_sertype* a, const ddsi_sertype* b) { return sertype_of(a)->keyed == sertype_of(b)->keyed; }
std::uint32_t st_hash(const ddsi_sertype* t) { return sertype_of(t)->keyed ? 1u : 0u; }

std::size_t st_get_serialized_size(const ddsi_sertype*, const void* sample) {
  return static_cast<const Bytes*>(sample)->size();
}
bool st_serialize_into(const ddsi_sertype*, const void* sample, void* dst, std::size_t dst_size) {
  const auto& bytes = *static_cast<const Bytes*>(sample);
  if (bytes.size() > dst_size) return false;
  std::memcpy(dst, bytes.data(), bytes.size());
  return true;
}

ddsi_sertype_ops make_sertype_ops() {
  ddsi_sertype_ops ops;
  std::memset(&ops, 0, sizeof ops);  // no type id/map/info (discovery by type name), no derivation
  ops.version = ddsi_sertype_v0;
  ops.free = st_free;
  ops.zero_samples = st_zero_samples;
  ops.realloc_samples = st_realloc_samples;
  ops.free_samples = st_free_samples;
  ops.equal = st_equal;
  ops.hash = st_hash;
  ops.get_serialized_size = st_get_serialized_size;
  ops.serialize_into = st_serialize_into;
  return ops;
}
const ddsi_sertype_ops kSertypeOps = make_sertype_ops();

// ---- domain, participant, writers, readers ----------------------------------------------------

std::string domain_xml(const TransportConfig& config) {
  std::string xml = "<CycloneDDS><Domain Id=\"any\"><General>";
  if (config.loopback_only) xml += "<Interfaces><NetworkInterface name=\"lo\"/></Interfaces>";
  if (!config.interfaces.empty()) {
    xml += "<Interfaces>";
    for (const std::string& a : config.interfaces) xml += "<NetworkInterface address=\"" + a + "\"/>";
    xml += "</Interfaces>";
  }
  // Multicast only across computers without configured peers (discovery needs it then).
  const bool multicast = !config.loopback_only && config.peers.empty();
  xml += multicast ? "<AllowMulticast>true</AllowMulticast>" : "<AllowMulticast>false</AllowMulticast>";
  // Loopback carries 64 KiB datagrams: fragments of ~60 KB instead of the default 1344 B take a
  // 1 MiB sample from ~1.4 ms to ~0.5 ms one way (Fast DDS uses 64 KiB messages by default too).
  if (config.loopback_only) xml += "<MaxMessageSize>65000B</MaxMessageSize><FragmentSize>62000B</FragmentSize>";
  xml += "</General>";
  xml += "<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>" +
         std::to_string(config.max_participants) + "</MaxAutoParticipantIndex><Peers>";
  for (const std::string& a : discovery_peers(config)) xml += "<Peer address=\"" + a + "\"/>";
  xml += "</Peers></Discovery>";
  const std::string bytes = std::to_string(config.socket_buffer_bytes) + "B";
  xml += "<Internal><SocketReceiveBufferSize max=\"" + bytes + "\"/><SocketSendBufferSize max=\"" + bytes +
         "\"/></Internal>";
  xml += "</Domain></CycloneDDS>";
  return xml;
}

/// One configured Cyclone domain per id and process, deleted with its last participant.
class Domains {
 public:
  static Domains& instance() {
    static Domains domains;
    return domains;
  }
  void acquire(const TransportConfig& config) {
    std::lock_guard<std::mutex> lock(mutex_);
    Use& use = domains_[config.domain_id];
    if (use.users == 0) {
      const dds_entity_t d = dds_create_domain(static_cast<dds_domainid_t>(config.domain_id), domain_xml(config).c_str());
      if (d < 0 && d != DDS_RETCODE_PRECONDITION_NOT_MET) {
        domains_.erase(config.domain_id);
        throw std::runtime_error("transport: Cyclone DDS could not create domain " +
                                 std::to_string(config.domain_id) + ": " + error_text(d));
      }
      if (d < 0) log()->warn("Cyclone DDS domain {} already exists in this process; its configuration is kept",
                             config.domain_id);
      use.handle = d < 0 ? 0 : d;
    }
    ++use.users;
  }
  void release(int domain_id) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = domains_.find(domain_id);
    if (it == domains_.end() || --it->second.users > 0) return;
    if (it->second.handle > 0) dds_delete(it->second.handle);
    domains_.erase(it);
  }

 private:
  struct Use {
    dds_entity_t handle = 0;
    int users = 0;
  };
  std::mutex mutex_;
  std::map<int, Use> domains_;
};

struct QosDeleter {
  void operator()(dds_qos_t* q) const { dds_delete_qos(q); }
};
using QosPtr = std::unique_ptr<dds_qos_t, QosDeleter>;

QosPtr endpoint_qos(const TopicQos& qos, bool writer) {
  QosPtr q(dds_create_qos());
  dds_qset_reliability(q.get(),
                       qos.reliability == Reliability::kReliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                       DDS_MSECS(100));
  const bool tl = qos.durability == Durability::kTransientLocal;
  dds_qset_durability(q.get(), tl ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  dds_qset_history(q.get(), DDS_HISTORY_KEEP_LAST, qos.depth);
  const dds_data_representation_id_t xcdr1 = DDS_DATA_REPRESENTATION_XCDR1;
  dds_qset_data_representation(q.get(), 1, &xcdr1);
  if (writer) {
    if (tl) {
      dds_qset_durability_service(q.get(), 0, DDS_HISTORY_KEEP_LAST, qos.depth, DDS_LENGTH_UNLIMITED,
                                  DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED);
    }
    dds_qset_writer_data_lifecycle(q.get(), false);
  }
  return q;
}

/// DDS Security with the builtin plugins (Debian's libddsc finds dds_security_auth, _ac and
/// _crypto in its private library directory): PKI-DH, access control, AES-GCM-GMAC.
void add_security_properties(dds_qos_t* q, const SecurityFiles& f) {
  dds_qset_prop(q, "dds.sec.auth.library.path", "dds_security_auth");
  dds_qset_prop(q, "dds.sec.auth.library.init", "init_authentication");
  dds_qset_prop(q, "dds.sec.auth.library.finalize", "finalize_authentication");
  dds_qset_prop(q, "dds.sec.crypto.library.path", "dds_security_crypto");
  dds_qset_prop(q, "dds.sec.crypto.library.init", "init_crypto");
  dds_qset_prop(q, "dds.sec.crypto.library.finalize", "finalize_crypto");
  dds_qset_prop(q, "dds.sec.access.library.path", "dds_security_ac");
  dds_qset_prop(q, "dds.sec.access.library.init", "init_access_control");
  dds_qset_prop(q, "dds.sec.access.library.finalize", "finalize_access_control");
  dds_qset_prop(q, "dds.sec.auth.identity_ca", ("file:" + f.identity_ca).c_str());
  dds_qset_prop(q, "dds.sec.auth.identity_certificate", ("file:" + f.certificate).c_str());
  dds_qset_prop(q, "dds.sec.auth.private_key", ("file:" + f.private_key).c_str());
  dds_qset_prop(q, "dds.sec.access.permissions_ca", ("file:" + f.permissions_ca).c_str());
  dds_qset_prop(q, "dds.sec.access.governance", ("file:" + f.governance).c_str());
  dds_qset_prop(q, "dds.sec.access.permissions", ("file:" + f.permissions).c_str());
}

/// The DDS participant and its topics; shared by the Participant and its writers/readers.
class Context {
 public:
  Context(const TransportConfig& config, const std::string& name)
      : domain_id_(config.domain_id), identity_(config.security.enabled ? security_identity(config.security, name) : "") {
    Domains::instance().acquire(config);
    QosPtr q(dds_create_qos());
    dds_qset_entity_name(q.get(), name.c_str());
    if (config.security.enabled) {
      try {
        add_security_properties(q.get(), security_files(config.security, name));
      } catch (...) {
        Domains::instance().release(domain_id_);
        throw;
      }
    }
    participant_ = dds_create_participant(static_cast<dds_domainid_t>(domain_id_), q.get(), nullptr);
    if (participant_ < 0) {
      Domains::instance().release(domain_id_);
      throw std::runtime_error("transport: Cyclone DDS could not create a participant on domain " +
                               std::to_string(domain_id_) + ": " + error_text(participant_) +
                               (config.security.enabled ? " (security on: a certificate, key or signed document was "
                                                          "refused; see the log above)"
                                                        : ""));
    }
    // transport.system_name: one publisher and one subscriber in that partition, parents of every
    // writer and reader, so that two systems on one domain never match (empty: the default one).
    QosPtr partition(dds_create_qos());
    if (!config.system_name.empty()) dds_qset_partition1(partition.get(), config.system_name.c_str());
    publisher_ = dds_create_publisher(participant_, partition.get(), nullptr);
    subscriber_ = dds_create_subscriber(participant_, partition.get(), nullptr);
    if (publisher_ < 0 || subscriber_ < 0) {
      const dds_return_t rc = publisher_ < 0 ? publisher_ : subscriber_;
      dds_delete(participant_);
      Domains::instance().release(domain_id_);
      throw std::runtime_error("transport: Cyclone DDS could not create a publisher/subscriber: " + error_text(rc));
    }
  }
  ~Context() {
    dds_delete(participant_);
    Domains::instance().release(domain_id_);
  }

  dds_entity_t participant() const { return participant_; }

  /// The name the participant that wrote a sample `reader` took gives itself (empty: unknown).
  std::string sender_name(dds_entity_t reader, dds_instance_handle_t publication) {
    dds_builtintopic_endpoint_t* endpoint = dds_get_matched_publication_data(reader, publication);
    if (endpoint == nullptr) return "";
    const dds_instance_handle_t owner = endpoint->participant_instance_handle;
    dds_builtintopic_free_endpoint(endpoint);
    std::lock_guard<std::mutex> lock(names_mutex_);
    if (participants_reader_ == 0) {
      participants_reader_ = dds_create_reader(participant_, DDS_BUILTIN_TOPIC_DCPSPARTICIPANT, nullptr, nullptr);
      if (participants_reader_ < 0) {
        participants_reader_ = 0;
        return "";
      }
    }
    void* samples[1] = {nullptr};
    dds_sample_info_t info;
    const dds_return_t n = dds_read_instance(participants_reader_, samples, &info, 1, 1, owner);
    std::string name;
    if (n > 0 && info.valid_data) {
      char* entity_name = nullptr;
      const auto* data = static_cast<const dds_builtintopic_participant_t*>(samples[0]);
      if (dds_qget_entity_name(data->qos, &entity_name) && entity_name != nullptr) name = entity_name;
      dds_free(entity_name);
    }
    if (n > 0) dds_return_loan(participants_reader_, samples, n);
    return name;
  }
  /// Why an endpoint may have been refused: the grant of this process's security identity.
  std::string refusal_hint(const std::string& what) const { return security_refusal_hint(identity_, what); }
  dds_entity_t publisher() const { return publisher_; }
  dds_entity_t subscriber() const { return subscriber_; }

  /// The topic of this name (created on first use with our sertype for the type).
  dds_entity_t topic(const std::string& name, const TypeSupport& type) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = topics_.find(name);
    if (it != topics_.end()) {
      if (it->second.type != type.name) {
        throw std::runtime_error("transport: topic '" + name + "' already has type " + it->second.type + ", not " +
                                 type.name);
      }
      return it->second.handle;
    }
    auto* st = new OpaqueSertype();
    st->keyed = type.keyed;
    ddsi_sertype_init_flags(&st->c, type.name.c_str(), &kSertypeOps, &kSerdataOps,
                            type.keyed ? 0u : DDSI_SERTYPE_FLAG_TOPICKIND_NO_KEY);
    st->c.allowed_data_representation = DDS_DATA_REPRESENTATION_FLAG_XCDR1;
    ddsi_sertype* actual = &st->c;
    const dds_entity_t t = dds_create_topic_sertype(participant_, name.c_str(), &actual, nullptr, nullptr, nullptr);
    if (t < 0) {
      st_free(&st->c);
      throw std::runtime_error("transport: Cyclone DDS could not create topic '" + name + "' of type " + type.name +
                               ": " + error_text(t) + refusal_hint("use"));
    }
    topics_[name] = TopicEntry{t, type.name};
    return t;
  }

 private:
  struct TopicEntry {
    dds_entity_t handle;
    std::string type;
  };
  int domain_id_;
  std::string identity_;  ///< the security identity (empty: security off)
  std::mutex names_mutex_;
  dds_entity_t participants_reader_ = 0;  ///< DCPSParticipant, made on the first sender_name()
  dds_entity_t participant_ = 0;
  dds_entity_t publisher_ = 0, subscriber_ = 0;  // deleted with the participant
  std::mutex mutex_;
  std::map<std::string, TopicEntry> topics_;  // deleted with the participant
};

class CycloneWriter : public RawWriter {
 public:
  CycloneWriter(std::shared_ptr<Context> context, const std::string& topic, const TypeSupport& type,
                const TopicQos& qos)
      : context_(std::move(context)), topic_(topic) {
    const dds_entity_t t = context_->topic(topic, type);
    writer_ = dds_create_writer(context_->publisher(), t, endpoint_qos(qos, true).get(), nullptr);
    if (writer_ < 0) {
      throw std::runtime_error("transport: Cyclone DDS could not create a writer on '" + topic +
                               "': " + error_text(writer_) + context_->refusal_hint("publish"));
    }
  }
  ~CycloneWriter() override { dds_delete(writer_); }

  bool write(const Bytes& sample) override {
    if (sample.size() < 4) {
      log()->warn("refused a sample of {} bytes on '{}' (no encapsulation header)", sample.size(), topic_);
      return false;
    }
    const dds_return_t rc = dds_write(writer_, &sample);
    if (rc == DDS_RETCODE_OK) return true;
    log()->warn("Cyclone DDS refused a sample of {} bytes on '{}': {}", sample.size(), topic_, error_text(rc));
    return false;
  }

  std::size_t matched_readers() const override {
    dds_publication_matched_status_t status{};
    if (dds_get_publication_matched_status(writer_, &status) != DDS_RETCODE_OK) return 0;
    return status.current_count;
  }

  bool wait_for_acknowledgments(std::chrono::milliseconds timeout) override {
    return dds_wait_for_acks(writer_, DDS_MSECS(timeout.count())) == DDS_RETCODE_OK;
  }

 private:
  std::shared_ptr<Context> context_;
  std::string topic_;
  dds_entity_t writer_ = 0;
};

class CycloneReader : public RawReader {
 public:
  CycloneReader(std::shared_ptr<Context> context, const std::string& topic, const TypeSupport& type,
                const TopicQos& qos, RawHandler handler)
      : context_(std::move(context)), topic_(topic), handler_(std::move(handler)) {
    const dds_entity_t t = context_->topic(topic, type);
    dds_listener_t* listener = dds_create_listener(this);
    dds_lset_data_available(listener, &CycloneReader::on_data_available);
    reader_ = dds_create_reader(context_->subscriber(), t, endpoint_qos(qos, false).get(), listener);
    dds_delete_listener(listener);
    if (reader_ < 0) {
      throw std::runtime_error("transport: Cyclone DDS could not create a reader on '" + topic +
                               "': " + error_text(reader_) + context_->refusal_hint("subscribe to"));
    }
  }
  ~CycloneReader() override {
    {
      std::lock_guard<std::mutex> lock(take_mutex_);
      closed_ = true;
    }
    dds_delete(reader_);  // waits for a listener call in progress
  }

  std::size_t matched_writers() const override {
    dds_subscription_matched_status_t status{};
    if (dds_get_subscription_matched_status(reader_, &status) != DDS_RETCODE_OK) return 0;
    return status.current_count;
  }

 private:
  static void on_data_available(dds_entity_t reader, void* arg) { static_cast<CycloneReader*>(arg)->drain(reader); }

  /// The sender of the sample in hand, looked up only when asked.
  class Sender : public SenderLookup {
   public:
    Sender(Context& context, dds_entity_t reader, dds_instance_handle_t publication)
        : context_(context), reader_(reader), publication_(publication) {}
    std::string sender() const override { return context_.sender_name(reader_, publication_); }

   private:
    Context& context_;
    dds_entity_t reader_;
    dds_instance_handle_t publication_;
  };

  void drain(dds_entity_t reader) {
    std::lock_guard<std::mutex> lock(take_mutex_);
    if (closed_) return;
    for (;;) {
      ddsi_serdata* sd = nullptr;
      dds_sample_info_t info;
      const dds_return_t n = dds_takecdr(reader, &sd, 1, &info, DDS_ANY_STATE);
      if (n <= 0) break;
      if (info.valid_data && sd != nullptr) {
        const Sender sender(*context_, reader, info.publication_handle);
        const SenderScope scope(&sender);
        deliver(sd);
      }
      if (sd != nullptr) ddsi_serdata_unref(sd);
    }
  }

  void deliver(const ddsi_serdata* sd) {
    const std::uint8_t* data = nullptr;
    std::size_t size = 0;
    if (sd->ops == &kSerdataOps) {  // ours: the bytes are right there
      data = serdata_of(sd)->data;
      size = serdata_of(sd)->size;
    } else {
      copy_.resize(ddsi_serdata_size(sd));
      ddsi_serdata_to_ser(sd, 0, copy_.size(), copy_.data());
      data = copy_.data();
      size = copy_.size();
    }
    try {
      handler_(data, unpadded_size(data, size));
    } catch (const std::exception& e) {
      log()->error("handler of '{}' threw: {}", topic_, e.what());
    }
  }

  std::shared_ptr<Context> context_;
  std::string topic_;
  RawHandler handler_;
  std::mutex take_mutex_;
  bool closed_ = false;
  Bytes copy_;
  dds_entity_t reader_ = 0;
};

class CycloneParticipant : public Participant {
 public:
  CycloneParticipant(const TransportConfig& config, const std::string& name)
      : context_(std::make_shared<Context>(config, name)) {}

  std::unique_ptr<RawWriter> create_writer(const std::string& topic, const TypeSupport& type,
                                           const TopicQos& qos) override {
    return std::make_unique<CycloneWriter>(context_, topic, type, qos);
  }
  std::unique_ptr<RawReader> create_reader(const std::string& topic, const TypeSupport& type, const TopicQos& qos,
                                           RawHandler handler) override {
    return std::make_unique<CycloneReader>(context_, topic, type, qos, std::move(handler));
  }
  std::string vendor() const override { return "cyclonedds"; }

 private:
  std::shared_ptr<Context> context_;
};

}  // namespace

std::unique_ptr<Participant> make_cyclonedds_participant(const TransportConfig& config, const std::string& name) {
  return std::make_unique<CycloneParticipant>(config, name);
}

}  // namespace fuse::transport::detail

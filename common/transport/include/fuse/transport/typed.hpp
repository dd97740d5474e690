// Typed publish/subscribe over a Participant: the generated fuse_msgs types are serialised
// once, by Fast CDR, as XCDR1 with the encapsulation header; both vendors carry the same bytes.
#pragma once

#include <atomic>
#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastcdr/exceptions/Exception.h>

#include <functional>
#include <memory>
#include <string>
#include <utility>

#include "fuse/transport/qos.hpp"
#include "fuse/transport/transport.hpp"

namespace fuse::transport {

/// IDL name of a generated type; specialised for every fuse_msgs type in msg_traits.hpp.
template <class T>
struct MsgName;

/// Largest serialised size of T, encapsulation included. Computed once: the generated
/// getMaxCdrSerializedSize() walks every element of a bounded sequence (~1 ms for a MapChunk).
template <class T>
std::size_t max_serialized_size() {
  static const std::size_t size = T::getMaxCdrSerializedSize() + 4;
  return size;
}

template <class T>
TypeSupport type_support() {
  return TypeSupport{MsgName<T>::value, T::isKeyDefined(), max_serialized_size<T>()};
}

template <class T>
Bytes serialize(const T& msg) {
  Bytes out(T::getCdrSerializedSize(msg) + 4);
  eprosima::fastcdr::FastBuffer buffer(reinterpret_cast<char*>(out.data()), out.size());
  eprosima::fastcdr::Cdr cdr(buffer, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN, eprosima::fastcdr::Cdr::DDS_CDR);
  cdr.serialize_encapsulation();
  msg.serialize(cdr);
  out.resize(cdr.getSerializedDataLength());
  return out;
}

/// Decodes one sample; false (with the reason in *error) on a malformed or oversized sample.
/// A received sample may carry up to 3 bytes of padding after the data (the RTPS payload is
/// padded to 4 bytes, and Fast DDS does not record the padding in the encapsulation options).
template <class T>
bool deserialize(const std::uint8_t* data, std::size_t size, T& msg, std::string* error = nullptr) {
  if (size < 4 || size > ((max_serialized_size<T>() + 3) & ~std::size_t{3})) {
    if (error) *error = "sample of " + std::to_string(size) + " bytes is outside the type's size range";
    return false;
  }
  try {
    eprosima::fastcdr::FastBuffer buffer(reinterpret_cast<char*>(const_cast<std::uint8_t*>(data)), size);
    eprosima::fastcdr::Cdr cdr(buffer, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN, eprosima::fastcdr::Cdr::DDS_CDR);
    cdr.read_encapsulation();
    msg.deserialize(cdr);
  } catch (const eprosima::fastcdr::exception::Exception& e) {
    if (error) *error = std::string("CDR decoding failed: ") + e.what();
    return false;
  } catch (const std::exception& e) {  // e.g. std::bad_alloc on an absurd sequence length
    if (error) *error = std::string("CDR decoding failed: ") + e.what();
    return false;
  }
  return true;
}

template <class T>
class Publisher {
 public:
  Publisher(Participant& participant, const std::string& topic)
      : writer_(participant.create_writer(topic, type_support<T>(), topic_qos(topic))) {}
  /// The topic's QoS with a writer history of `depth` samples instead of the table's: a
  /// transient-local writer that holds more for late or restarted readers (KEEP_LAST depths of
  /// writer and reader need not match).
  Publisher(Participant& participant, const std::string& topic, int depth)
      : writer_(participant.create_writer(topic, type_support<T>(), with_depth(topic_qos(topic), depth))) {}
  bool publish(const T& msg) { return writer_->write(serialize(msg)); }
  /// Publishes a sample already serialised as T (encapsulation header included), e.g. by a
  /// direct codec that writes the same CDR without building T (io::encode_scan).
  bool publish_serialized(const Bytes& sample) { return writer_->write(sample); }
  std::size_t matched() const { return writer_->matched_readers(); }
  /// See RawWriter::wait_for_acknowledgments.
  bool wait_for_acknowledgments(std::chrono::milliseconds timeout) { return writer_->wait_for_acknowledgments(timeout); }

 private:
  std::unique_ptr<RawWriter> writer_;
};

/// Calls `on_sample` (on a backend thread) for every well-formed sample; malformed samples are
/// counted and passed to `on_malformed` with the reason.
template <class T>
class Subscriber {
 public:
  using Handler = std::function<void(const T&)>;
  using ErrorHandler = std::function<void(const std::string&)>;

  Subscriber(Participant& participant, const std::string& topic, Handler on_sample, ErrorHandler on_malformed = {})
      : on_sample_(std::move(on_sample)), on_malformed_(std::move(on_malformed)) {
    reader_ = participant.create_reader(topic, type_support<T>(), topic_qos(topic),
                                        [this](const std::uint8_t* data, std::size_t size) { receive(data, size); });
  }
  /// The topic's QoS with a reader history of `depth` samples: a reader that must not lose the
  /// samples of a burst on a topic whose table depth is for late joiners (e.g. state/corrected).
  Subscriber(Participant& participant, const std::string& topic, int depth, Handler on_sample,
             ErrorHandler on_malformed = {})
      : on_sample_(std::move(on_sample)), on_malformed_(std::move(on_malformed)) {
    reader_ = participant.create_reader(topic, type_support<T>(), with_depth(topic_qos(topic), depth),
                                        [this](const std::uint8_t* data, std::size_t size) { receive(data, size); });
  }
  ~Subscriber() { reader_.reset(); }  // stop callbacks before the handlers go away
  Subscriber(const Subscriber&) = delete;
  Subscriber& operator=(const Subscriber&) = delete;

  std::uint64_t received() const { return received_; }
  std::uint64_t malformed() const { return malformed_; }
  std::size_t matched() const { return reader_->matched_writers(); }

 private:
  void receive(const std::uint8_t* data, std::size_t size) {
    T msg;
    std::string error;
    if (!deserialize(data, size, msg, &error)) {
      ++malformed_;
      if (on_malformed_) on_malformed_(error);
      return;
    }
    ++received_;
    on_sample_(msg);
  }

  Handler on_sample_;
  ErrorHandler on_malformed_;
  std::atomic<std::uint64_t> received_{0}, malformed_{0};
  std::unique_ptr<RawReader> reader_;
};

/// Subscribes to a topic of type T but hands each sample over as bytes, for a reader that
/// decodes T's CDR itself (io::decode_scan); that decoder checks the bytes.
template <class T>
class RawSubscriber {
 public:
  RawSubscriber(Participant& participant, const std::string& topic, RawHandler on_sample) {
    reader_ = participant.create_reader(topic, type_support<T>(), topic_qos(topic), std::move(on_sample));
  }
  ~RawSubscriber() { reader_.reset(); }  // stop callbacks before the handler's owner goes away
  RawSubscriber(const RawSubscriber&) = delete;
  RawSubscriber& operator=(const RawSubscriber&) = delete;
  std::size_t matched() const { return reader_->matched_writers(); }

 private:
  std::unique_ptr<RawReader> reader_;
};

}  // namespace fuse::transport

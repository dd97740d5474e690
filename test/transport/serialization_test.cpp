// Serialisation (Fast CDR, XCDR1 with the encapsulation header): every wire type survives a round
// trip with all fields set, and decoding refuses truncated and malformed bytes without crashing.
#include <cstring>
#include <random>

#include "backends.hpp"
#include "test_util.hpp"

namespace fuse::transport::test {
namespace {

template <class T>
void expect_round_trip(const T& sent) {
  const Bytes bytes = serialize(sent);
  ASSERT_GE(bytes.size(), 4u);
  EXPECT_EQ(bytes[0], 0x00);  // CDR, plain (XCDR1)
  EXPECT_LE(bytes[1], 0x01);
  T received;
  std::string error;
  ASSERT_TRUE(deserialize(bytes.data(), bytes.size(), received, &error)) << MsgName<T>::value << ": " << error;
  EXPECT_TRUE(received == sent) << MsgName<T>::value;
  EXPECT_EQ(serialize(received), bytes) << MsgName<T>::value;
}

template <class T>
void expect_truncation_refused(const T& sent) {
  const Bytes bytes = serialize(sent);
  // Every strict prefix lacks at least the last field; check many of them (all for small types).
  const std::size_t step = std::max<std::size_t>(1, bytes.size() / 257);
  for (std::size_t n = 0; n < bytes.size(); n += step) {
    T received;
    EXPECT_FALSE(deserialize(bytes.data(), n, received)) << MsgName<T>::value << " cut to " << n << " bytes";
  }
  T received;
  EXPECT_FALSE(deserialize(bytes.data(), bytes.size() - 1, received)) << MsgName<T>::value;
}

TEST(Serialization, EveryTypeRoundTrips) {
  for_each_type([](auto tag) {
    using T = decltype(tag);
    expect_round_trip(Sample<T>::make(3));
  });
}

TEST(Serialization, LargeAndEmptySequencesRoundTrip) {
  expect_round_trip(make_scan(1, 0));
  expect_round_trip(make_scan(2, 50000));
  fuse_msgs::MapChunk chunk = make_chunk(0xFFFFFFFFFFFFFFFFull, 9);
  chunk.points(points3f(4, 100000));
  expect_round_trip(chunk);
  fuse_msgs::Health empty_counters = make_health(1);
  empty_counters.counters().clear();
  empty_counters.last_error("");
  expect_round_trip(empty_counters);
}

TEST(Serialization, TrailingPaddingIsAccepted) {
  // RTPS pads payloads to 4 bytes: a Health ending in a 2-character error (its string ends
  // with 3 bytes) arrives with padding after it.
  auto sent = make_health(2);
  sent.last_error("ab");
  Bytes bytes = serialize(sent);
  const std::size_t pad = (4 - bytes.size() % 4) % 4;
  ASSERT_GT(pad, 0u) << "the sample must not end on a 4-byte boundary";
  bytes.resize(bytes.size() + pad, 0);
  fuse_msgs::Health received;
  ASSERT_TRUE(deserialize(bytes.data(), bytes.size(), received));
  EXPECT_TRUE(received == sent);
  // The padding declared in the encapsulation options is removed by the backends.
  bytes[3] = static_cast<std::uint8_t>(pad);
  EXPECT_EQ(detail::unpadded_size(bytes.data(), bytes.size()), bytes.size() - pad);
  bytes[3] = 0;
  EXPECT_EQ(detail::unpadded_size(bytes.data(), bytes.size()), bytes.size());
}

TEST(Serialization, TruncatedSamplesAreRefused) {
  for_each_type([](auto tag) {
    using T = decltype(tag);
    expect_truncation_refused(Sample<T>::make(5));
  });
}

TEST(Serialization, MalformedSamplesAreRefused) {
  std::string error;
  {  // a sequence length far beyond the bytes present
    Bytes bytes = serialize(make_scan(1, 4));
    const std::size_t length_at = bytes.size() - 4 * 24;  // the 4 points follow their length
    const std::uint32_t huge = 0x0FFFFFFF;
    std::memcpy(bytes.data() + length_at - 4, &huge, 4);
    fuse_msgs::LidarScan scan;
    EXPECT_FALSE(deserialize(bytes.data(), bytes.size(), scan, &error));
    EXPECT_FALSE(error.empty());
  }
  {  // a string length beyond the end
    Bytes bytes = serialize(make_imu(1));
    const std::uint32_t huge = 0x7FFFFFFF;
    std::memcpy(bytes.data() + 4 + 8 + 48 + 8, &huge, 4);  // t, gyro, accel, sequence_number, frame
    fuse_msgs::ImuSample imu;
    EXPECT_FALSE(deserialize(bytes.data(), bytes.size(), imu, &error));
  }
  {  // a boolean that is neither 0 nor 1
    fuse_msgs::Correction c = make_correction(1);
    Bytes bytes = serialize(c);
    c.converged(!c.converged());
    const Bytes flipped = serialize(c);
    ASSERT_EQ(bytes.size(), flipped.size());
    std::size_t at = 0;
    while (at < bytes.size() && bytes[at] == flipped[at]) ++at;
    ASSERT_LT(at, bytes.size());
    bytes[at] = 7;  // where `converged` is
    EXPECT_FALSE(deserialize(bytes.data(), bytes.size(), c, &error));
  }
  {  // larger than the type can ever be
    Bytes bytes(max_serialized_size<fuse_msgs::ImuSample>() + 4, 0);
    bytes[1] = 1;
    fuse_msgs::ImuSample imu;
    EXPECT_FALSE(deserialize(bytes.data(), bytes.size(), imu, &error));
    EXPECT_NE(error.find("size range"), std::string::npos);
  }
  {  // an encapsulation that is not CDR
    Bytes bytes = serialize(make_imu(1));
    bytes[0] = 0x7F;
    bytes[1] = 0x35;
    fuse_msgs::ImuSample imu;
    EXPECT_FALSE(deserialize(bytes.data(), bytes.size(), imu, &error));
  }
}

TEST(Serialization, RandomBytesNeverCrashTheDecoder) {
  std::mt19937 rng(42);
  std::size_t refused = 0, total = 0;
  for (int i = 0; i < 300; ++i) {
    Bytes bytes(4 + rng() % 600);
    for (auto& b : bytes) b = static_cast<std::uint8_t>(rng());
    bytes[0] = 0;
    bytes[1] = static_cast<std::uint8_t>(rng() & 1);
    for_each_type([&](auto tag) {
      using T = decltype(tag);
      T msg;
      refused += deserialize(bytes.data(), bytes.size(), msg) ? 0 : 1;
      ++total;
    });
  }
  EXPECT_GT(refused, total / 2);  // most garbage does not even have consistent lengths
}

TEST(Serialization, KeyHashFollowsTheEncapsulationEndianness) {
  // The hash both backends give a MapChunk: its key big-endian, zero-padded to 16 bytes, read
  // from little- and big-endian samples alike.
  const std::array<std::uint8_t, 16> expected{1, 2, 3, 4, 5, 6, 7, 8, 0, 0, 0, 0, 0, 0, 0, 0};
  Bytes le = serialize(make_chunk(0x0102030405060708ull, 1));
  ASSERT_EQ(le[1], 0x01);  // this machine writes little endian
  Bytes be = le;
  be[1] = 0x00;
  for (int i = 0; i < 8; ++i) be[4 + i] = le[4 + 7 - i];
  std::array<std::uint8_t, 16> hash{};
  EXPECT_TRUE(detail::key_hash_from_sample(le.data(), le.size(), hash));
  EXPECT_EQ(hash, expected);
  EXPECT_TRUE(detail::key_hash_from_sample(be.data(), be.size(), hash));
  EXPECT_EQ(hash, expected);
  EXPECT_FALSE(detail::key_hash_from_sample(le.data(), 11, hash));
  EXPECT_EQ(hash, (std::array<std::uint8_t, 16>{}));
}

}  // namespace
}  // namespace fuse::transport::test

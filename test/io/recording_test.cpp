// Recording layer: CDR codec of the samples, RecordingWriter -> MCAP -> McapSource round trip,
// arrival order, calibration metadata and the validation counters of the source.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <set>

#include "fuse/io/cdr_codec.hpp"
#include "fuse/io/mcap_reader.hpp"
#include "fuse/io/mcap_writer.hpp"
#include "fuse/io/recording.hpp"
#include "fuse/io/source_validator.hpp"
#include "fuse_idl_text.hpp"
#include "test_util.hpp"

namespace fuse::io {
namespace {

using test::TempDir;

ImuSample make_imu(double t, std::uint64_t seq) {
  ImuSample s;
  s.t = t;
  s.gyro = Eigen::Vector3d(0.01 * seq, -0.2, 0.3 + 1e-12 * seq);
  s.accel = Eigen::Vector3d(0.1, std::sin(t), 9.81);
  s.sequence = seq;
  return s;
}

LidarScan make_scan(double t_start, double t_end, std::uint64_t seq, std::size_t n) {
  LidarScan s;
  s.t_start = t_start;
  s.t_end = t_end;
  s.sequence = seq;
  for (std::size_t i = 0; i < n; ++i) {
    const float a = static_cast<float>(i);
    s.points.push_back({a * 0.01f, -a * 0.02f, 1.5f, a, static_cast<float>((t_end - t_start) * i / std::max<std::size_t>(n, 1)),
                        static_cast<std::uint16_t>(i % 4)});
  }
  return s;
}

void expect_same(const ImuSample& a, const ImuSample& b) {
  EXPECT_EQ(a.t, b.t);
  EXPECT_EQ(a.gyro, b.gyro);
  EXPECT_EQ(a.accel, b.accel);
  EXPECT_EQ(a.sequence, b.sequence);
}

void expect_same(const LidarScan& a, const LidarScan& b) {
  EXPECT_EQ(a.t_start, b.t_start);
  EXPECT_EQ(a.t_end, b.t_end);
  EXPECT_EQ(a.sequence, b.sequence);
  ASSERT_EQ(a.points.size(), b.points.size());
  for (std::size_t i = 0; i < a.points.size(); ++i) {
    EXPECT_EQ(a.points[i].x, b.points[i].x);
    EXPECT_EQ(a.points[i].y, b.points[i].y);
    EXPECT_EQ(a.points[i].z, b.points[i].z);
    EXPECT_EQ(a.points[i].intensity, b.points[i].intensity);
    EXPECT_EQ(a.points[i].t_rel, b.points[i].t_rel);
    EXPECT_EQ(a.points[i].ring, b.points[i].ring);
  }
}

TEST(CdrCodec, ImuRoundTripWithEncapsulationHeader) {
  const ImuSample imu = make_imu(1234.5678901234, 42);
  const auto bytes = encode_imu(imu, "imu_link");
  ASSERT_GE(bytes.size(), 4u);
  EXPECT_EQ(bytes[0], 0x00);  // CDR little-endian, XCDR1
  EXPECT_EQ(bytes[1], 0x01);
  EXPECT_EQ(bytes[2], 0x00);
  EXPECT_EQ(bytes[3], 0x00);
  EXPECT_EQ(bytes.size(), 4u + 64u + 4u + 9u);  // 7 doubles + u64, string length + "imu_link\0"
  std::string frame;
  expect_same(decode_imu(kImuSchemaName, bytes.data(), bytes.size(), &frame), imu);
  EXPECT_EQ(frame, "imu_link");
}

TEST(CdrCodec, ScanRoundTrip) {
  const LidarScan scan = make_scan(10.0, 10.1, 7, 1001);
  const auto bytes = encode_scan(scan, "lidar");
  std::string frame;
  expect_same(decode_scan(kLidarScanSchemaName, bytes.data(), bytes.size(), &frame), scan);
  EXPECT_EQ(frame, "lidar");
  const LidarScan empty = make_scan(1.0, 1.1, 0, 0);
  const auto empty_bytes = encode_scan(empty, "lidar");
  expect_same(decode_scan(kLidarScanSchemaName, empty_bytes.data(), empty_bytes.size()), empty);
}

TEST(CdrCodec, RejectsWrongSchemaSizesAndEncapsulation) {
  const auto imu = encode_imu(make_imu(1.0, 1), "imu");
  EXPECT_THROW(decode_imu(kLidarScanSchemaName, imu.data(), imu.size()), InputError);
  for (std::size_t n = 0; n < imu.size(); ++n) {
    EXPECT_THROW(decode_imu(kImuSchemaName, imu.data(), n), InputError) << "truncated to " << n;
  }
  auto longer = imu;
  longer.resize(imu.size() + 4);
  EXPECT_THROW(decode_imu(kImuSchemaName, longer.data(), longer.size()), InputError);
  auto xcdr2 = imu;
  xcdr2[1] = 0x07;  // PL_CDR2 little-endian: not what the recording writes
  EXPECT_THROW(decode_imu(kImuSchemaName, xcdr2.data(), xcdr2.size()), InputError);

  const auto scan = encode_scan(make_scan(1.0, 1.1, 1, 50), "lidar");
  for (std::size_t n = 0; n < scan.size(); n += 7) {
    EXPECT_THROW(decode_scan(kLidarScanSchemaName, scan.data(), n), InputError) << "truncated to " << n;
  }
  // The point count sits after 24 bytes of times/sequence and the 4 + 6 byte frame string,
  // aligned to 4: body offset 36, file offset 40. A corrupted count is caught before decoding.
  auto bad_count = scan;
  bad_count[40] = 0xFF;
  bad_count[41] = 0xFF;
  EXPECT_THROW(decode_scan(kLidarScanSchemaName, bad_count.data(), bad_count.size()), InputError);
  auto long_frame = scan;
  long_frame[28] = 200;  // frame length beyond MAX_FRAME_ID
  EXPECT_THROW(decode_scan(kLidarScanSchemaName, long_frame.data(), long_frame.size()), InputError);
}

TEST(CdrCodec, RefusesToEncodeBeyondIdlBounds) {
  EXPECT_THROW(encode_imu(make_imu(1.0, 1), std::string(65, 'f')), std::invalid_argument);
}

Eigen::Isometry3d test_calibration() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(-0.011, -0.02329, 0.04412);
  return T;
}

class RecordingRoundTrip : public ::testing::TestWithParam<Compression> {};

// 2 s of 200 Hz IMU and 10 Hz scans: the MCAP has the promised channels/schemas/metadata, and
// the source returns every sample unchanged in arrival order with the calibration.
TEST_P(RecordingRoundTrip, SourceReturnsWhatWasWritten) {
  TempDir dir;
  const std::string path = dir.file("rec.mcap");
  std::vector<ImuSample> imus;
  std::vector<LidarScan> scans;
  {
    RecordingWriterConfig config;
    config.compression = GetParam();
    config.chunk_size_bytes = 256 * 1024;
    RecordingWriter w(path, config);
    w.set_calibration(test_calibration());
    for (int i = 0; i <= 400; ++i) {
      imus.push_back(make_imu(100.0 + 0.005 * i, i));
      w.write(imus.back());
      if (i % 20 == 0 && i > 0) {
        // Written after the IMU sample of the same time; the scan arrives at its end time.
        scans.push_back(make_scan(100.0 + 0.005 * (i - 20), 100.0 + 0.005 * i, scans.size(), 2000));
        w.write(scans.back());
      }
    }
    w.close();
  }
  {
    McapReader r(path);
    ASSERT_EQ(r.channels().size(), 2u);
    for (const auto& [id, c] : r.channels()) {
      EXPECT_EQ(c.message_encoding, "cdr");
      const auto& schema = r.schemas().at(c.schema_id);
      EXPECT_EQ(schema.encoding, "omgidl");
      EXPECT_EQ(std::string(schema.data.begin(), schema.data.end()), fuse::msgs::kIdlText);
      EXPECT_EQ(schema.name, c.topic == kImuTopic ? "fuse_msgs::ImuSample" : "fuse_msgs::LidarScan");
    }
    ASSERT_EQ(r.metadata().size(), 1u);
    EXPECT_EQ(r.metadata()[0].name, kCalibrationMetadata);
    EXPECT_EQ(r.metadata()[0].metadata.at("tx"), "-0.010999999999999999");  // 17 significant digits
    EXPECT_EQ(r.statistics()->message_count, imus.size() + scans.size());
    McapMessage m;
    r.start();
    ASSERT_TRUE(r.next(m));
    EXPECT_EQ(m.header.log_time, 100'000'000'000ull);
    EXPECT_NO_THROW(r.verify());
  }
  auto source = open_sensor_source(path);
  ASSERT_TRUE(source->T_imu_lidar().has_value());
  EXPECT_TRUE(source->T_imu_lidar()->isApprox(test_calibration(), 1e-15));
  EXPECT_EQ(source->T_imu_lidar()->translation(), test_calibration().translation());
  std::size_t ni = 0, ns = 0;
  double last = -1.0;
  SensorEvent e;
  SensorEvent::Kind last_kind = SensorEvent::Kind::kImu;
  while (source->next(e)) {
    EXPECT_GE(e.arrival_time(), last);
    if (e.arrival_time() == last) {
      EXPECT_FALSE(e.kind == SensorEvent::Kind::kImu && last_kind == SensorEvent::Kind::kLidar) << "tie: IMU first";
    }
    last = e.arrival_time();
    last_kind = e.kind;
    if (e.kind == SensorEvent::Kind::kImu) {
      ASSERT_LT(ni, imus.size());
      expect_same(e.imu, imus[ni++]);
    } else {
      ASSERT_LT(ns, scans.size());
      expect_same(e.scan, scans[ns++]);
    }
  }
  EXPECT_EQ(ni, imus.size());
  EXPECT_EQ(ns, scans.size());
  EXPECT_EQ(source->stats().imu_samples, imus.size());
  EXPECT_EQ(source->stats().scans, scans.size());
  EXPECT_TRUE(source->stats().rejected.empty());
  EXPECT_NE(source->describe().find("MCAP"), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(AllCompressions, RecordingRoundTrip,
                         ::testing::Values(Compression::kNone, Compression::kZstd, Compression::kLz4));

// A scan written before the IMU sample of the same time still comes after it.
TEST(McapSource, TiesPutImuFirst) {
  TempDir dir;
  const std::string path = dir.file("tie.mcap");
  {
    RecordingWriter w(path);
    w.write(make_imu(1.0, 0));
    w.write(make_scan(1.0, 1.1, 0, 10));
    w.write(make_imu(1.1, 1));
    w.write(make_imu(1.2, 2));
  }
  auto source = open_sensor_source(path);
  EXPECT_FALSE(source->T_imu_lidar().has_value());
  std::vector<SensorEvent::Kind> kinds;
  SensorEvent e;
  while (source->next(e)) kinds.push_back(e.kind);
  using K = SensorEvent::Kind;
  EXPECT_EQ(kinds, (std::vector<K>{K::kImu, K::kImu, K::kLidar, K::kImu}));
}

// The count a progress percentage divides by: the IMU and LiDAR messages of the statistics.
TEST(McapSource, ExpectedEventsAreTheSensorMessagesOfTheStatistics) {
  TempDir dir;
  const std::string path = dir.file("count.mcap");
  {
    RecordingWriter w(path);
    for (int i = 0; i < 30; ++i) w.write(make_imu(1.0 + 0.005 * i, i));
    w.write(make_scan(1.0, 1.1, 0, 10));
    w.write(make_scan(1.1, 1.2, 1, 10));
  }
  auto source = open_sensor_source(path);
  ASSERT_TRUE(source->expected_events().has_value());
  EXPECT_EQ(*source->expected_events(), 32u);
  std::uint64_t n = 0;
  SensorEvent e;
  while (source->next(e)) ++n;
  EXPECT_EQ(n, *source->expected_events());
}

// seek(t) continues with the first event at or after t, as reading and dropping everything
// before it would, and reads only the chunks from there (a restarted real-time replay).
TEST(McapSource, SeekContinuesAtTheFirstEventFromThatTime) {
  TempDir dir;
  const std::string path = dir.file("seek.mcap");
  RecordingWriterConfig config;
  config.chunk_size_bytes = 16 * 1024;
  {
    RecordingWriter w(path, config);
    for (int i = 0; i <= 2000; ++i) {
      w.write(make_imu(100.0 + 0.005 * i, i));
      if (i % 20 == 0 && i > 0) w.write(make_scan(100.0 + 0.005 * (i - 20), 100.0 + 0.005 * i, i / 20, 300));
    }
  }
  const double t = 106.0025;  // between two IMU samples
  std::vector<SensorEvent> expected;
  {
    auto all = open_sensor_source(path);
    SensorEvent e;
    while (all->next(e)) {
      if (e.arrival_time() >= t) expected.push_back(e);
    }
  }
  auto source = open_sensor_source(path);
  SensorEvent e;
  ASSERT_TRUE(source->next(e));  // read a little first, as ingest does to find the first time
  ASSERT_TRUE(source->seek(t));
  std::size_t n = 0;
  while (source->next(e)) {
    ASSERT_LT(n, expected.size());
    ASSERT_EQ(e.kind, expected[n].kind) << n;
    EXPECT_EQ(e.arrival_time(), expected[n].arrival_time()) << n;
    ++n;
  }
  EXPECT_EQ(n, expected.size());
  EXPECT_EQ(n, 800u + 40u);  // 4 s of 200 Hz IMU and 10 Hz scans
  EXPECT_TRUE(source->stats().rejected.empty()) << "nothing refused as out of order after the jump";
  McapReader reader(path);
  ASSERT_TRUE(reader.has_summary());
  McapReadOptions from_t;
  from_t.start_time = 106'002'500'000ull;
  reader.start(from_t);
  McapMessage m;
  while (reader.next(m)) {
  }
  reader.start();
  std::size_t all_blocks = 0;
  while (reader.next(m)) {
  }
  all_blocks = reader.blocks_loaded();
  reader.start(from_t);
  while (reader.next(m)) {
  }
  EXPECT_LT(reader.blocks_loaded(), all_blocks * 6 / 10) << "the chunks before t are not read";
}

// --- Salvage of truncated recordings --------------------------------------------------------

/// A recording of 2 s (200 Hz IMU, 10 Hz scans of 300 points) in chunks of about 16 KiB.
void write_chunked_recording(const std::string& path, Compression compression) {
  RecordingWriterConfig config;
  config.compression = compression;
  config.chunk_size_bytes = 16 * 1024;
  RecordingWriter w(path, config);
  w.set_calibration(test_calibration());
  for (int i = 0; i <= 400; ++i) {
    w.write(make_imu(10.0 + 0.005 * i, i));
    if (i % 20 == 0 && i > 0) w.write(make_scan(10.0 + 0.005 * (i - 20), 10.0 + 0.005 * i, i / 20, 300));
  }
  w.close();
}

template <typename T>
T read_le(const std::vector<std::uint8_t>& bytes, std::size_t offset) {
  T v{};
  std::memcpy(&v, bytes.data() + offset, sizeof v);  // MCAP integers are little-endian, as is the host
  return v;
}

/// Where each chunk of a complete file ends and how many messages it holds. Read independently of
/// the salvage path: the ChunkIndex records of the summary and the MessageIndex records after
/// each chunk (spec: opcode 0x07, channel id u16, then an array of 16-byte (log_time, offset)).
struct ChunkExtent {
  std::uint64_t end = 0;
  std::size_t messages = 0;
};
std::vector<ChunkExtent> chunk_extents(const std::string& path) {
  const auto bytes = test::read_bytes(path);
  McapReader reader(path);
  std::vector<ChunkExtent> out;
  for (const auto& ci : reader.chunk_indexes()) {
    ChunkExtent c{ci.chunk_start_offset + ci.chunk_length, 0};
    for (const auto& [channel, offset] : ci.message_index_offsets) {
      EXPECT_EQ(bytes.at(offset), 0x07) << "MessageIndex expected at " << offset;
      EXPECT_EQ(read_le<std::uint16_t>(bytes, offset + 9), channel);
      c.messages += read_le<std::uint32_t>(bytes, offset + 11) / 16;
    }
    out.push_back(c);
  }
  return out;
}

/// Messages in the chunks that end at or before byte `n`.
std::size_t messages_before(const std::vector<ChunkExtent>& chunks, std::uint64_t n) {
  std::size_t count = 0;
  for (const auto& c : chunks) count += c.end <= n ? c.messages : 0;
  return count;
}

void expect_same(const SensorEvent& a, const SensorEvent& b) {
  ASSERT_EQ(a.kind, b.kind);
  if (a.kind == SensorEvent::Kind::kImu) {
    expect_same(a.imu, b.imu);
  } else {
    expect_same(a.scan, b.scan);
  }
}

/// Every event of a source until it ends; `error` receives the InputError that ended it, if any.
std::vector<SensorEvent> drain(SensorSource& source, std::string& error) {
  std::vector<SensorEvent> events;
  SensorEvent e;
  try {
    while (source.next(e)) events.push_back(e);
  } catch (const InputError& x) {
    error = x.what();
  }
  return events;
}

/// Byte counts to cut a file of `size` bytes at: the head, a sweep, every chunk end +-1, the tail.
std::vector<std::uint64_t> cut_points(std::uint64_t size, const std::vector<ChunkExtent>& chunks) {
  std::vector<std::uint64_t> cuts;
  for (std::uint64_t n = 0; n < 120; ++n) cuts.push_back(n);
  for (std::uint64_t k = 1; k < 120; ++k) cuts.push_back(size * k / 120);
  for (const auto& c : chunks) cuts.insert(cuts.end(), {c.end - 1, c.end, c.end + 1});
  for (std::uint64_t n = 1; n <= 120; ++n) cuts.push_back(size - n);
  return cuts;
}

class TruncatedRecording : public ::testing::TestWithParam<Compression> {};

// A recording cut at any byte: the source yields exactly the messages of the chunks complete
// before the cut (the full file's first events, same order and content), then raises
// InputError naming the file and the truncation. Never a clean end, never another exception.
TEST_P(TruncatedRecording, YieldsTheCompleteChunksThenReportsTheTruncation) {
  TempDir dir;
  const std::string full_path = dir.file("full.mcap"), cut_path = dir.file("cut.mcap");
  write_chunked_recording(full_path, GetParam());
  const auto chunks = chunk_extents(full_path);
  ASSERT_GE(chunks.size(), 8u);
  std::string error;
  const auto full = drain(*open_sensor_source(full_path), error);
  ASSERT_TRUE(error.empty()) << error;
  ASSERT_EQ(full.size(), messages_before(chunks, UINT64_MAX));  // clean data: one event per message

  const auto bytes = test::read_bytes(full_path);
  std::set<std::size_t> counts_seen;
  for (const std::uint64_t n : cut_points(bytes.size(), chunks)) {
    SCOPED_TRACE("cut to " + std::to_string(n) + " of " + std::to_string(bytes.size()) + " bytes");
    test::write_bytes(cut_path, bytes, n);
    const std::size_t expected = messages_before(chunks, n);
    std::unique_ptr<SensorSource> source;
    try {
      source = open_sensor_source(cut_path);
    } catch (const InputError& e) {
      EXPECT_EQ(expected, 0u) << "open failed: " << e.what();  // only a file cut inside its Header
      continue;
    }
    error.clear();
    const auto got = drain(*source, error);
    ASSERT_EQ(got.size(), expected);
    for (std::size_t i = 0; i < got.size(); ++i) expect_same(got[i], full[i]);
    EXPECT_NE(error.find("truncated"), std::string::npos) << error;
    EXPECT_NE(error.find(cut_path), std::string::npos) << error;
    EXPECT_NE(error.find("byte offset " + std::to_string(n)), std::string::npos) << error;
    counts_seen.insert(expected);
  }
  EXPECT_GE(counts_seen.size(), chunks.size() + 1) << "cuts before, between and after every chunk";
}

INSTANTIATE_TEST_SUITE_P(AllCompressions, TruncatedRecording,
                         ::testing::Values(Compression::kNone, Compression::kZstd, Compression::kLz4),
                         [](const auto& info) {
                           return info.param == Compression::kNone   ? std::string("none")
                                  : info.param == Compression::kZstd ? std::string("zstd")
                                                                     : std::string("lz4");
                         });

// Cut inside the first chunk: the schemas, channels and calibration before it are read, no
// event is delivered, and the first next() raises the truncation.
TEST(McapSource, FileCutInsideTheFirstChunkYieldsNothingThenThrows) {
  TempDir dir;
  write_chunked_recording(dir.file("full.mcap"), Compression::kZstd);
  McapReader full(dir.file("full.mcap"));
  ASSERT_FALSE(full.chunk_indexes().empty());
  const auto& first = full.chunk_indexes().front();
  const auto bytes = test::read_bytes(dir.file("full.mcap"));
  test::write_bytes(dir.file("cut.mcap"), bytes, first.chunk_start_offset + first.chunk_length / 2);

  auto source = open_sensor_source(dir.file("cut.mcap"));
  EXPECT_TRUE(source->T_imu_lidar().has_value());
  EXPECT_NE(source->describe().find("salvage"), std::string::npos);
  SensorEvent e;
  try {
    source->next(e);
    ADD_FAILURE() << "a truncated file must end in InputError";
  } catch (const InputError& x) {
    const std::string what = x.what();
    EXPECT_NE(what.find("truncated"), std::string::npos) << what;
    EXPECT_NE(what.find("recovered 0 messages"), std::string::npos) << what;
    EXPECT_NE(what.find("Chunk record at offset " + std::to_string(first.chunk_start_offset)), std::string::npos) << what;
  }
  EXPECT_THROW(source->next(e), InputError);  // and keeps failing
}

// Bad samples inside a well-formed recording are dropped/repaired and counted by reason;
// unknown channels are ignored and counted once each.
TEST(McapSource, CountsRejectedSamples) {
  TempDir dir;
  const std::string path = dir.file("bad.mcap");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  {
    McapWriter w(path);
    const auto si = w.add_schema(kImuSchemaName, kSchemaEncoding, fuse::msgs::kIdlText);
    const auto ss = w.add_schema(kLidarScanSchemaName, kSchemaEncoding, fuse::msgs::kIdlText);
    const auto ci = w.add_channel(si, kImuTopic, kMessageEncoding);
    const auto cs = w.add_channel(ss, kLidarTopic, kMessageEncoding);
    const auto other = w.add_channel(0, "diagnostics", "json");
    std::uint32_t seq = 0;
    auto put_imu = [&](const ImuSample& s, std::uint64_t t_ns) {
      const auto b = encode_imu(s, "imu");
      w.write_message(ci, seq++, t_ns, t_ns, b.data(), b.size());
    };
    auto put_scan = [&](const LidarScan& s, std::uint64_t t_ns) {
      const auto b = encode_scan(s, "lidar");
      w.write_message(cs, seq++, t_ns, t_ns, b.data(), b.size());
    };
    put_imu(make_imu(1.0, 0), 1'000'000'000);
    auto nan_imu = make_imu(1.01, 1);
    nan_imu.gyro.y() = nan;
    put_imu(nan_imu, 1'010'000'000);
    put_imu(make_imu(0.5, 2), 1'020'000'000);  // sample time going backwards
    put_imu(make_imu(1.03, 3), 1'030'000'000);
    for (int k = 0; k < 3; ++k) w.write_message(other, seq++, 1'040'000'000, 1'040'000'000, nullptr, 0);
    auto nan_points = make_scan(1.0, 1.1, 0, 100);
    nan_points.points[3].x = static_cast<float>(nan);
    nan_points.points[7].t_rel = std::numeric_limits<float>::infinity();
    put_scan(nan_points, 1'100'000'000);
    put_scan(make_scan(1.2, 1.15, 1, 10), 1'150'000'000);  // ends before it starts
    put_scan(make_scan(0.9, 1.05, 2, 10), 1'160'000'000);  // end before the previous scan's end
    put_scan(make_scan(1.1, 1.2, 3, 0), 1'200'000'000);    // empty: passed on
  }
  auto source = open_sensor_source(path);
  std::size_t imus = 0, scans = 0, points = 0;
  SensorEvent e;
  while (source->next(e)) {
    if (e.kind == SensorEvent::Kind::kImu) {
      ++imus;
    } else {
      ++scans;
      points += e.scan.points.size();
    }
  }
  EXPECT_EQ(imus, 2u);
  EXPECT_EQ(scans, 2u);
  EXPECT_EQ(points, 98u);
  const auto& r = source->stats().rejected;
  EXPECT_EQ(r.at(reason::kNanImu), 1u);
  EXPECT_EQ(r.at(reason::kImuOutOfOrder), 1u);
  EXPECT_EQ(r.at(reason::kNanPoints), 2u);
  EXPECT_EQ(r.at(reason::kScanEndBeforeStart), 1u);
  EXPECT_EQ(r.at(reason::kScanOutOfOrder), 1u);
  EXPECT_EQ(r.at(reason::kEmptyScan), 1u);
  EXPECT_EQ(r.at(reason::kUnknownChannel), 1u);
  EXPECT_EQ(source->stats().imu_samples, 2u);
  EXPECT_EQ(source->stats().scans, 2u);
}

TEST(McapSource, RejectsWrongTypesAndBadCalibration) {
  TempDir dir;
  {
    McapWriter w(dir.file("wrong_schema.mcap"));
    const auto s = w.add_schema("fuse_msgs::StateEstimate", kSchemaEncoding, fuse::msgs::kIdlText);
    w.add_channel(s, kImuTopic, kMessageEncoding);
  }
  EXPECT_THROW(open_sensor_source(dir.file("wrong_schema.mcap")), InputError);
  {
    McapWriter w(dir.file("bad_calib.mcap"));
    w.write_metadata(kCalibrationMetadata, {{"tx", "1"}, {"ty", "x"}, {"tz", "0"}, {"qx", "0"}, {"qy", "0"}, {"qz", "0"}, {"qw", "1"}});
  }
  EXPECT_THROW(open_sensor_source(dir.file("bad_calib.mcap")), InputError);
  {
    McapWriter w(dir.file("garbage_sample.mcap"));
    const auto s = w.add_schema(kImuSchemaName, kSchemaEncoding, fuse::msgs::kIdlText);
    const auto c = w.add_channel(s, kImuTopic, kMessageEncoding);
    const std::uint8_t junk[10] = {0, 1, 0, 0, 1, 2, 3, 4, 5, 6};
    w.write_message(c, 0, 1, 1, junk, sizeof junk);
  }
  auto source = open_sensor_source(dir.file("garbage_sample.mcap"));
  SensorEvent e;
  EXPECT_THROW(source->next(e), InputError);
  EXPECT_THROW(open_sensor_source(dir.file("does_not_exist")), InputError);
}

}  // namespace
}  // namespace fuse::io

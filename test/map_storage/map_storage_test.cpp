// Snapshot and journal files (map_storage.hpp): round trips, journal replay, the crash between
// snapshot rename and journal reset, and damage (bad CRC, truncation, bad header) being found,
// reported with file and byte offset, and the good part kept.
#include "fuse/map/map_storage.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "core_fixtures.hpp"
#include "test_files.hpp"

namespace fuse {
namespace {

using test::expect_same_map;
using test::TempDir;

MapObservation observation(std::uint64_t session, std::uint64_t sequence, int n = 50) {
  MapObservation o;
  o.session = session;
  o.sequence = sequence;
  o.t = 100.0 + 0.1 * static_cast<double>(sequence);
  for (int i = 0; i < n; ++i) {
    const float s = static_cast<float>(sequence);
    o.points.emplace_back(-30.f + 1.3f * static_cast<float>(i) + s, 0.5f * s - 7.f, 0.01f * static_cast<float>(i) - 2.f);
  }
  return o;
}

/// A map spread over chunks with negative and positive coordinates.
PointMap sample_map(double chunk_size = 10.0) {
  PointMap map(chunk_size);
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 300; ++i) {
    const float f = static_cast<float>(i);
    points.emplace_back(-45.f + 0.31f * f, 20.f - 0.17f * f, std::sin(f) * 3.f);
  }
  map.insert(points);
  map.insert({{-1, -1, -1}, {55, 55, 55}});
  return map;
}

struct Loaded {
  PointMap map;
  MapMeta meta;
  LoadReport report;
  std::vector<MapObservation> replayed;
};

Loaded load(MapStorage& storage) {
  Loaded out;
  out.report = storage.load(out.map, out.meta, [&](const MapObservation& o) { out.replayed.push_back(o); });
  return out;
}

/// A map directory whose journal holds observations 1..count of session.
void write_journal(const std::filesystem::path& dir, std::uint64_t session, std::uint64_t count) {
  MapStorage storage(dir);
  load(storage);
  for (std::uint64_t s = 1; s <= count; ++s) storage.append(observation(session, s));
}

TEST(MapStorage, SnapshotFileRoundTrip) {
  TempDir dir;
  const PointMap map = sample_map();
  MapMeta meta;
  meta.min_point_distance = 0.2;
  meta.mode = "localization";
  meta.epoch = 3;
  meta.observations = 42;
  meta.acks.restore(7, 12, {});
  meta.acks.restore(0xFFFFFFFFFFFFull, 1, {{4, 6}, {9, 9}});  // durable above a hole, the most recent
  meta.acks.restore(3, 0, {});                                 // nothing acknowledged, the newest
  const auto file = dir / "copy.snapshot";
  MapStorage::write_snapshot_file(file, map, meta);
  EXPECT_FALSE(std::filesystem::exists(dir / "copy.snapshot.tmp"));

  PointMap back(1.0);
  MapMeta meta_back;
  const LoadReport report = MapStorage::read_snapshot_file(file, back, meta_back);
  EXPECT_TRUE(report.clean()) << report.summary();
  EXPECT_TRUE(report.snapshot_ok);
  EXPECT_EQ(report.chunks_loaded, map.num_chunks());
  expect_same_map(map, back);
  EXPECT_EQ(meta_back.frame_id, "world");
  EXPECT_EQ(meta_back.min_point_distance, 0.2);
  EXPECT_EQ(meta_back.mode, "localization");
  EXPECT_EQ(meta_back.epoch, 3u);
  EXPECT_EQ(meta_back.observations, 42u);
  EXPECT_EQ(meta_back.acks, meta.acks);
  EXPECT_EQ(meta_back.acks.acked(0xFFFFFFFFFFFFull), 1u);
  EXPECT_TRUE(meta_back.acks.covered(0xFFFFFFFFFFFFull, 5));
  EXPECT_FALSE(meta_back.acks.covered(0xFFFFFFFFFFFFull, 7));
  EXPECT_EQ(meta_back.acks.by_activity(), (std::vector<std::uint64_t>{3, 0xFFFFFFFFFFFFull, 7}))
      << "the order of activity is kept";
  EXPECT_FALSE(meta_back.gravity.has_value()) << "a writer that did not know gravity records none";
}

TEST(MapStorage, SnapshotKeepsTheMapsGravityDirection) {
  TempDir dir;
  const PointMap map = sample_map();
  MapMeta meta;
  meta.gravity = Eigen::Vector3d(0.01, -0.02, -1.0);  // stored as a unit vector
  const auto file = dir / "gravity.snapshot";
  MapStorage::write_snapshot_file(file, map, meta);
  PointMap back(1.0);
  MapMeta meta_back;
  ASSERT_TRUE(MapStorage::read_snapshot_file(file, back, meta_back).snapshot_ok);
  ASSERT_TRUE(meta_back.gravity.has_value());
  EXPECT_LT((*meta_back.gravity - meta.gravity->normalized()).norm(), 1e-12);
}

TEST(MapStorage, JournalReplaysAppendedObservationsInOrder) {
  TempDir dir;
  {
    MapStorage storage(dir.path());
    Loaded fresh = load(storage);
    EXPECT_TRUE(fresh.report.clean());
    EXPECT_FALSE(fresh.report.snapshot_found);
    EXPECT_FALSE(fresh.report.journal_found);
    for (std::uint64_t s = 1; s <= 4; ++s) storage.append(observation(9, s));
    storage.append(observation(5, 1, 0));  // an empty observation is a record too
    EXPECT_EQ(storage.journal_records(), 5u);
  }
  MapStorage storage(dir.path());
  const Loaded back = load(storage);
  EXPECT_TRUE(back.report.clean()) << back.report.summary();
  ASSERT_EQ(back.replayed.size(), 5u);
  for (std::uint64_t s = 1; s <= 4; ++s) {
    const MapObservation expected = observation(9, s);
    EXPECT_EQ(back.replayed[s - 1].session, 9u);
    EXPECT_EQ(back.replayed[s - 1].sequence, s);
    EXPECT_EQ(back.replayed[s - 1].t, expected.t);
    EXPECT_EQ(back.replayed[s - 1].points, expected.points);
  }
  EXPECT_TRUE(back.replayed[4].points.empty());
  EXPECT_EQ(back.meta.acks.acked(9), 4u);
  EXPECT_EQ(back.meta.acks.acked(5), 1u);
  EXPECT_EQ(back.meta.observations, 5u);
  EXPECT_EQ(storage.journal_records(), 5u);
}

TEST(MapStorage, SnapshotRestartsTheJournal) {
  TempDir dir;
  const PointMap map = sample_map();
  {
    MapStorage storage(dir.path());
    load(storage);
    storage.append(observation(1, 1));
    MapMeta meta;
    meta.acks.add_durable(1, 1);
    meta.observations = 1;
    storage.snapshot(map, meta);
    EXPECT_EQ(storage.journal_records(), 0u);
    storage.append(observation(1, 2));
  }
  MapStorage storage(dir.path());
  const Loaded back = load(storage);
  EXPECT_TRUE(back.report.clean()) << back.report.summary();
  expect_same_map(map, back.map);
  ASSERT_EQ(back.replayed.size(), 1u);
  EXPECT_EQ(back.replayed[0].sequence, 2u);
  EXPECT_EQ(back.meta.acks.acked(1), 2u);
  EXPECT_EQ(back.meta.observations, 2u);
}

TEST(MapStorage, CrashBetweenSnapshotRenameAndJournalResetAppliesNothingTwice) {
  TempDir dir;
  {
    MapStorage storage(dir.path());
    load(storage);
    for (std::uint64_t s = 1; s <= 5; ++s) storage.append(observation(3, s));
    storage.append(observation(4, 1));
  }
  // The snapshot covers session 3 up to 3 and session 4 fully; the journal was not reset.
  MapMeta meta;
  meta.acks.restore(3, 3, {});
  meta.acks.restore(4, 1, {});
  MapStorage::write_snapshot_file(dir / MapStorage::kSnapshotName, sample_map(), meta);

  MapStorage storage(dir.path());
  const Loaded back = load(storage);
  EXPECT_TRUE(back.report.clean()) << back.report.summary();
  EXPECT_EQ(back.report.journal_records, 6u);
  EXPECT_EQ(back.report.journal_skipped, 4u);
  ASSERT_EQ(back.replayed.size(), 2u);
  EXPECT_EQ(back.replayed[0].sequence, 4u);
  EXPECT_EQ(back.replayed[1].sequence, 5u);
  EXPECT_EQ(back.meta.acks.acked(3), 5u);
}

TEST(MapStorage, CorruptedJournalRecordIsSkippedAndEveryLaterRecordKept) {
  TempDir dir;
  write_journal(dir.path(), 2, 6);
  const auto journal = dir / MapStorage::kJournalName;
  const auto offsets = test::record_offsets(journal);
  ASSERT_EQ(offsets.size(), 6u);
  const auto size = std::filesystem::file_size(journal);
  test::flip_byte(journal, offsets[3] + 20);  // inside the 4th record's bytes
  {
    MapStorage storage(dir.path());
    const Loaded back = load(storage);
    EXPECT_FALSE(back.report.clean());
    ASSERT_EQ(back.replayed.size(), 5u);
    EXPECT_EQ(back.replayed[3].sequence, 5u);
    EXPECT_EQ(back.replayed[4].points, observation(2, 6).points);
    EXPECT_EQ(back.report.journal_records, 5u);
    EXPECT_EQ(back.report.journal_records_lost, 1u);
    EXPECT_EQ(back.report.journal_bytes_cut, 0u);
    ASSERT_EQ(back.report.damaged.size(), 1u);
    EXPECT_EQ(back.report.damaged[0].offset, offsets[3]);
    EXPECT_EQ(back.report.damaged[0].bytes, offsets[4] - offsets[3]);
    EXPECT_TRUE(test::mentions(back.report.problems, "map.journal: byte " + std::to_string(offsets[3])))
        << back.report.problems.at(0);
    EXPECT_TRUE(test::mentions(back.report.problems, "CRC"));
    EXPECT_EQ(std::filesystem::file_size(journal), size) << "nothing cut: good records follow the damage";
    EXPECT_EQ(back.meta.acks.acked(2), 3u);
    EXPECT_TRUE(back.meta.acks.covered(2, 6));
    EXPECT_TRUE(storage.damaged());
    storage.append(observation(2, 4));  // appends follow the good records
  }
  {
    MapStorage storage(dir.path());
    const Loaded again = load(storage);
    EXPECT_EQ(again.report.damaged.size(), 1u) << "still there until a snapshot settles it";
    ASSERT_EQ(again.replayed.size(), 6u);
    EXPECT_EQ(again.meta.acks.acked(2), 6u);
    storage.snapshot(again.map, again.meta);
    EXPECT_TRUE(std::filesystem::exists(dir / "map.journal.bad.1")) << "the damaged journal is kept beside";
    EXPECT_EQ(std::filesystem::file_size(dir / "map.journal.bad.1"), size + offsets[4] - offsets[3]);
  }
  MapStorage storage(dir.path());
  const Loaded settled = load(storage);
  EXPECT_TRUE(settled.report.clean()) << settled.report.summary();
  EXPECT_EQ(settled.meta.acks.acked(2), 6u);
}

TEST(MapStorage, CorruptedLastJournalRecordIsCutAndAppendsContinue) {
  TempDir dir;
  write_journal(dir.path(), 2, 6);
  const auto journal = dir / MapStorage::kJournalName;
  const auto offsets = test::record_offsets(journal);
  test::flip_byte(journal, offsets[5] + 20);
  {
    MapStorage storage(dir.path());
    const Loaded back = load(storage);
    EXPECT_EQ(back.replayed.size(), 5u);
    EXPECT_EQ(back.report.journal_bytes_cut, std::filesystem::file_size(dir / "map.journal.cut.1"));
    EXPECT_TRUE(test::mentions(back.report.problems, "byte " + std::to_string(offsets[5])));
    EXPECT_EQ(std::filesystem::file_size(journal), offsets[5]);
    EXPECT_FALSE(storage.damaged()) << "a cut tail needs no snapshot";
    storage.append(observation(2, 6));
  }
  MapStorage storage(dir.path());
  const Loaded again = load(storage);
  EXPECT_TRUE(again.report.clean()) << again.report.summary();
  ASSERT_EQ(again.replayed.size(), 6u);
  EXPECT_EQ(again.replayed[5].points, observation(2, 6).points);
}

TEST(MapStorage, ResyncSkipsGarbageAndAZeroedBlock) {
  TempDir dir;
  write_journal(dir.path(), 3, 9);
  const auto journal = dir / MapStorage::kJournalName;
  const auto offsets = test::record_offsets(journal);
  {
    // Record 3 zeroed whole (a lost block), records 6 and 7 overwritten by bytes that look like
    // frames (small lengths, zero CRCs).
    std::fstream f(journal, std::ios::binary | std::ios::in | std::ios::out);
    f.seekp(static_cast<std::streamoff>(offsets[2]));
    f.write(std::string(offsets[3] - offsets[2], '\0').data(), static_cast<std::streamsize>(offsets[3] - offsets[2]));
    std::string junk;
    for (std::uint64_t at = offsets[5]; at < offsets[7]; ++at) junk.push_back(static_cast<char>(at % 7 == 0 ? 0x08 : at % 5));
    f.seekp(static_cast<std::streamoff>(offsets[5]));
    f.write(junk.data(), static_cast<std::streamsize>(junk.size()));
  }
  MapStorage storage(dir.path(), true, MapStorage::Access::kReadOnly);
  const Loaded back = load(storage);
  ASSERT_EQ(back.report.damaged.size(), 2u) << back.report.summary();
  EXPECT_EQ(back.report.damaged[0].offset, offsets[2]);
  EXPECT_EQ(back.report.damaged[0].bytes, offsets[3] - offsets[2]);
  EXPECT_EQ(back.report.damaged[1].offset, offsets[5]);
  EXPECT_EQ(back.report.damaged[1].bytes, offsets[7] - offsets[5]);
  std::vector<std::uint64_t> sequences;
  for (const auto& o : back.replayed) sequences.push_back(o.sequence);
  EXPECT_EQ(sequences, (std::vector<std::uint64_t>{1, 2, 4, 5, 8, 9}));
  EXPECT_EQ(back.report.journal_records_lost, 3u);
  EXPECT_EQ(back.report.bytes_skipped(), offsets[3] - offsets[2] + offsets[7] - offsets[5]);
}

TEST(MapStorage, TruncatedJournalTailIsCutAndReported) {
  TempDir dir;
  write_journal(dir.path(), 2, 3);
  const auto journal = dir / MapStorage::kJournalName;
  const auto offsets = test::record_offsets(journal);
  test::truncate_to(journal, std::filesystem::file_size(journal) - 7);  // a torn last write
  {
    MapStorage storage(dir.path());
    const Loaded back = load(storage);
    EXPECT_EQ(back.replayed.size(), 2u);
    EXPECT_TRUE(test::mentions(back.report.problems, "byte " + std::to_string(offsets[2])));
    EXPECT_TRUE(test::mentions(back.report.problems, "truncated"));
    EXPECT_EQ(std::filesystem::file_size(journal), offsets[2]);
    storage.append(observation(2, 3));
  }
  MapStorage storage(dir.path());
  const Loaded again = load(storage);
  EXPECT_TRUE(again.report.clean()) << again.report.summary();
  EXPECT_EQ(again.replayed.size(), 3u);
}

TEST(MapStorage, CorruptedChunkRecordLosesOnlyThatChunk) {
  TempDir dir;
  const PointMap map = sample_map();
  ASSERT_GE(map.num_chunks(), 4u);
  const auto file = dir / "map.snapshot";
  MapStorage::write_snapshot_file(file, map, MapMeta{});
  const auto offsets = test::record_offsets(file);
  ASSERT_EQ(offsets.size(), map.num_chunks() + 1);  // header + chunks
  test::flip_byte(file, offsets[2] + 12);           // the second chunk's bytes

  PointMap back(1.0);
  MapMeta meta;
  const LoadReport report = MapStorage::read_snapshot_file(file, back, meta);
  EXPECT_TRUE(report.snapshot_ok);
  EXPECT_EQ(report.chunks_dropped, 1u);
  EXPECT_EQ(report.chunks_loaded, map.num_chunks() - 1);
  ASSERT_EQ(report.problems.size(), 1u);
  EXPECT_TRUE(test::mentions(report.problems, "byte " + std::to_string(offsets[2]))) << report.problems[0];
  // Every other chunk is intact.
  std::size_t lost = 0;
  map.for_each_chunk([&](const PointChunk& c) {
    const PointChunk* b = back.chunk(c.key);
    if (b == nullptr) {
      ++lost;
      return;
    }
    EXPECT_EQ(b->points, c.points);
  });
  EXPECT_EQ(lost, 1u);
}

TEST(MapStorage, TruncatedSnapshotKeepsTheChunksBeforeTheCut) {
  TempDir dir;
  const PointMap map = sample_map();
  const auto file = dir / "map.snapshot";
  MapStorage::write_snapshot_file(file, map, MapMeta{});
  const auto offsets = test::record_offsets(file);
  const std::size_t chunks = map.num_chunks();

  // Cut inside the last chunk record.
  test::truncate_to(file, offsets.back() + 10);
  PointMap back(1.0);
  MapMeta meta;
  LoadReport report = MapStorage::read_snapshot_file(file, back, meta);
  EXPECT_TRUE(report.snapshot_ok);
  EXPECT_EQ(report.chunks_loaded, chunks - 1);
  EXPECT_EQ(report.chunks_dropped, 1u);
  EXPECT_TRUE(test::mentions(report.problems, "truncated"));

  // Cut exactly between records: the header's chunk count tells.
  test::truncate_to(file, offsets[offsets.size() - 2]);
  report = MapStorage::read_snapshot_file(file, back, meta);
  EXPECT_TRUE(report.snapshot_ok);
  EXPECT_EQ(report.chunks_loaded, chunks - 2);
  EXPECT_EQ(report.chunks_dropped, 2u);
  EXPECT_TRUE(test::mentions(report.problems, "of " + std::to_string(chunks) + " chunk records"));
}

TEST(MapStorage, BadSnapshotHeaderStartsFromTheJournalOnly) {
  TempDir dir;
  {
    MapStorage storage(dir.path());
    load(storage);
    storage.append(observation(1, 1));
    MapMeta meta;
    meta.acks.add_durable(1, 1);
    storage.snapshot(sample_map(), meta);
    storage.append(observation(1, 2));
  }
  const auto snapshot = dir / MapStorage::kSnapshotName;
  test::flip_byte(snapshot, 12 + 8 + 3);  // inside the header record
  {
    MapStorage storage(dir.path());
    const Loaded back = load(storage);
    EXPECT_TRUE(back.report.snapshot_found);
    EXPECT_FALSE(back.report.snapshot_ok);
    EXPECT_EQ(back.map.num_points(), 0u);
    ASSERT_EQ(back.replayed.size(), 1u);
    EXPECT_EQ(back.replayed[0].sequence, 2u);
    EXPECT_TRUE(test::mentions(back.report.problems, "byte 12"));
    EXPECT_TRUE(test::mentions(back.report.problems, "starting from the journal only"));
    EXPECT_TRUE(std::filesystem::exists(dir / "map.snapshot.bad.1"));
    EXPECT_FALSE(std::filesystem::exists(snapshot));
  }
  // Not a snapshot at all (bad magic), read directly.
  std::ofstream(dir / "junk", std::ios::binary) << "definitely not a map snapshot";
  PointMap map(1.0);
  MapMeta meta;
  const LoadReport junk = MapStorage::read_snapshot_file(dir / "junk", map, meta);
  EXPECT_FALSE(junk.snapshot_ok);
  EXPECT_TRUE(test::mentions(junk.problems, "not a map snapshot"));
  const LoadReport missing = MapStorage::read_snapshot_file(dir / "absent", map, meta);
  EXPECT_FALSE(missing.snapshot_found);
  EXPECT_FALSE(missing.problems.empty());
}

TEST(MapStorage, ReadOnlyAccessChangesNothing) {
  TempDir dir;
  write_journal(dir.path(), 2, 3);
  const auto journal = dir / MapStorage::kJournalName;
  const auto size = std::filesystem::file_size(journal);
  test::truncate_to(journal, size - 3);
  MapStorage reader(dir.path(), true, MapStorage::Access::kReadOnly);
  const Loaded back = load(reader);
  EXPECT_EQ(back.replayed.size(), 2u);
  EXPECT_TRUE(test::mentions(back.report.problems, "ignored"));
  EXPECT_EQ(std::filesystem::file_size(journal), size - 3);
  EXPECT_THROW(reader.append(observation(2, 4)), std::logic_error);
}

TEST(MapStorage, UnwritableDirectoryLoadsButDoesNotWriteAndTheDirectoryIsLocked) {
  TempDir dir;
  std::ofstream(dir / "a_file") << "x";
  MapStorage unwritable(dir / "a_file" / "map");  // not an error until something is written
  const Loaded empty = load(unwritable);
  EXPECT_EQ(empty.map.num_points(), 0u);
  EXPECT_FALSE(unwritable.writable());
  EXPECT_NE(unwritable.write_error().find("cannot create map directory"), std::string::npos) << unwritable.write_error();
  EXPECT_FALSE(unwritable.make_writable());
  EXPECT_EQ(unwritable.append(std::vector<const MapObservation*>{}), 0u);
  EXPECT_THROW(unwritable.append(observation(1, 1)), MapStorageError);
  EXPECT_THROW(unwritable.snapshot(sample_map(), MapMeta{}), MapStorageError);

  MapStorage first(dir / "map");
  EXPECT_THROW(MapStorage(dir / "map"), MapDirectoryLocked);
}

TEST(MapStorage, FsyncOffStillWritesEverything) {
  TempDir dir;
  {
    MapStorage storage(dir.path(), false);
    load(storage);
    storage.append(observation(1, 1));
    storage.snapshot(sample_map(), MapMeta{});
    storage.append(observation(1, 2));
  }
  MapStorage storage(dir.path(), false);
  const Loaded back = load(storage);
  EXPECT_TRUE(back.report.clean());
  EXPECT_EQ(back.replayed.size(), 1u);
  expect_same_map(sample_map(), back.map);
}

}  // namespace
}  // namespace fuse

// Map server core (map_server_core.hpp): restart equivalence, duplicates, modes, save/load and
// damaged files, all without DDS.
#include "fuse/map/map_server_core.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <limits>

#include "core_fixtures.hpp"
#include "test_files.hpp"

namespace fuse {
namespace {

using test::config_in;
using test::expect_same_map;
using test::scan;
using test::TempDir;

/// Applies sequences [from, to] of two interleaved sessions.
void feed(MapServerCore& core, std::uint64_t from, std::uint64_t to) {
  for (std::uint64_t s = from; s <= to; ++s) {
    core.apply(11, s, 0.1 * static_cast<double>(s), scan(11, s));
    core.apply(22, s, 0.1 * static_cast<double>(s), scan(22, s, 100));
  }
}

void expect_restart_equivalence(std::size_t snapshot_every) {
  TempDir dir;
  PointMap before(1.0);
  std::map<std::uint64_t, std::uint64_t> acked_before;
  MapServerStats stats_before;
  {
    MapServerCore core(config_in(dir.path(), snapshot_every));
    feed(core, 1, 15);
    before = core.map();
    acked_before = core.acked_sequences();
    stats_before = core.stats();
    EXPECT_EQ(core.index().size(), core.map().num_points());
  }
  MapServerCore core(config_in(dir.path(), snapshot_every));
  EXPECT_TRUE(core.load_report().clean()) << core.load_report().summary();
  expect_same_map(before, core.map());
  EXPECT_EQ(core.acked_sequences(), acked_before);
  EXPECT_EQ(core.acked(11), 15u);
  EXPECT_EQ(core.stats().observations_applied, stats_before.observations_applied);
  EXPECT_EQ(core.index().size(), core.map().num_points());
  // ... and it goes on exactly as the first instance would have.
  MapServerCore reference_dir_less(config_in(dir / "reference", 0));
  feed(reference_dir_less, 1, 18);
  feed(core, 16, 18);
  expect_same_map(reference_dir_less.map(), core.map());
}

TEST(MapServerCore, RestartFromJournalOnlyGivesTheSameMapAndAcks) { expect_restart_equivalence(0); }

TEST(MapServerCore, RestartFromSnapshotsAndJournalGivesTheSameMapAndAcks) { expect_restart_equivalence(7); }

TEST(MapServerCore, ApplyReportsInsertedPointsAndChangedChunks) {
  TempDir dir;
  MapServerCore core(config_in(dir.path()));
  const auto first = core.apply(1, 1, 0.0, scan(1, 1));
  EXPECT_TRUE(first.applied);
  EXPECT_FALSE(first.duplicate);
  EXPECT_EQ(first.acked, 1u);
  EXPECT_GT(first.inserted, 0u);
  EXPECT_EQ(core.map().num_points(), first.inserted);
  EXPECT_EQ(first.changed_chunks.size(), core.map().num_chunks());
  // The same points again: all within min_point_distance of the map, nothing changes.
  const auto again = core.apply(1, 2, 0.1, scan(1, 1));
  EXPECT_TRUE(again.applied);
  EXPECT_EQ(again.inserted, 0u);
  EXPECT_TRUE(again.changed_chunks.empty());
  // Changed chunks are exactly those whose revision moved.
  std::map<std::uint64_t, std::uint64_t> revisions;
  core.map().for_each_chunk([&](const PointChunk& c) { revisions[c.key] = c.revision; });
  const auto third = core.apply(1, 3, 0.2, scan(1, 9));
  std::size_t moved = 0;
  core.map().for_each_chunk([&](const PointChunk& c) {
    const bool changed = std::binary_search(third.changed_chunks.begin(), third.changed_chunks.end(), c.key);
    EXPECT_EQ(changed, revisions[c.key] != c.revision) << c.coord.transpose();
    moved += changed;
  });
  EXPECT_EQ(moved, third.changed_chunks.size());
}

TEST(MapServerCore, KeepsTheFirstMappingSessionsGravityInItsSnapshots) {
  TempDir dir;
  const Eigen::Vector3d g = Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitX()) * Eigen::Vector3d(0, 0, -9.81);
  {
    MapServerCore core(config_in(dir.path()));
    EXPECT_FALSE(core.gravity().has_value()) << "a new map knows no gravity";
    EXPECT_FALSE(core.note_gravity(Eigen::Vector3d(0, 9.81, 0), 0.35)) << "gravity along y is no map frame's";
    EXPECT_FALSE(core.gravity().has_value());
    EXPECT_TRUE(core.note_gravity(g, 0.35));
    EXPECT_TRUE(core.note_gravity(Eigen::Vector3d(0, 0, -1), 0.35));  // a later session's: the first is kept
    ASSERT_TRUE(core.gravity().has_value());
    EXPECT_LT((*core.gravity() - g.normalized()).norm(), 1e-12);
    core.apply(1, 1, 0.0, scan(1, 1));
    core.save();
  }
  MapServerCore restarted(config_in(dir.path()));
  ASSERT_TRUE(restarted.gravity().has_value()) << "the snapshot keeps it";
  EXPECT_LT((*restarted.gravity() - g.normalized()).norm(), 1e-9);
}

TEST(MapServerCore, DuplicatesAreAcknowledgedButAppliedOnce) {
  TempDir dir;
  {
    MapServerCore core(config_in(dir.path()));
    core.apply(5, 1, 0.0, scan(5, 1));
    core.apply(5, 2, 0.1, scan(5, 2));
    const std::size_t points = core.map().num_points();
    const std::size_t records = core.stats().journal_records;
    for (std::uint64_t s : {2, 1, 2}) {
      const auto r = core.apply(5, s, 0.0, scan(5, 7));  // different points: must not matter
      EXPECT_TRUE(r.duplicate);
      EXPECT_FALSE(r.applied);
      EXPECT_EQ(r.acked, 2u);
    }
    EXPECT_EQ(core.map().num_points(), points);
    EXPECT_EQ(core.stats().journal_records, records);
    EXPECT_EQ(core.stats().duplicates, 3u);
    EXPECT_EQ(core.stats().observations_applied, 2u);
    // Another session's sequence 1 is not a duplicate.
    EXPECT_FALSE(core.apply(6, 1, 0.0, scan(6, 1)).duplicate);
  }
  MapServerCore core(config_in(dir.path()));
  EXPECT_TRUE(core.apply(5, 2, 0.0, scan(5, 2)).duplicate);
  EXPECT_EQ(core.stats().observations_applied, 3u);
}

TEST(MapServerCore, CrashBetweenSnapshotAndJournalResetAppliesNothingTwice) {
  TempDir dir;
  PointMap before(1.0);
  const auto journal = dir / MapStorage::kJournalName;
  const auto kept = dir / "journal.before_snapshot";
  {
    MapServerCore core(config_in(dir.path()));
    feed(core, 1, 6);
    std::filesystem::copy_file(journal, kept);
    core.save();
    EXPECT_EQ(core.stats().journal_records, 0u);
    before = core.map();
  }
  // As if the process died after the snapshot's rename, before the journal restarted.
  std::filesystem::copy_file(kept, journal, std::filesystem::copy_options::overwrite_existing);
  MapServerCore core(config_in(dir.path()));
  EXPECT_TRUE(core.load_report().clean()) << core.load_report().summary();
  EXPECT_EQ(core.load_report().journal_skipped, 12u);
  EXPECT_EQ(core.load_report().journal_replayed, 0u);
  expect_same_map(before, core.map());
  EXPECT_EQ(core.stats().observations_applied, 12u);
}

TEST(MapServerCore, DamagedJournalKeepsEveryGoodRecordAndSnapshotsAtOnce) {
  TempDir dir;
  {
    MapServerCore core(config_in(dir.path()));
    for (std::uint64_t s = 1; s <= 8; ++s) core.apply(3, s, 0.0, scan(3, s));
  }
  const auto journal = dir / MapStorage::kJournalName;
  const auto offsets = test::record_offsets(journal);
  ASSERT_EQ(offsets.size(), 8u);
  test::flip_byte(journal, offsets[5] + 100);  // observation 6
  {
    MapServerCore core(config_in(dir.path()));
    EXPECT_FALSE(core.load_report().clean());
    EXPECT_EQ(core.load_report().journal_replayed, 7u) << "7 and 8 follow the damage and are kept";
    EXPECT_EQ(core.load_report().journal_records_lost, 1u);
    EXPECT_EQ(core.acked(3), 5u) << "6 is missing: 7 and 8 are durable above the hole";
    EXPECT_TRUE(core.session_acks().covered(3, 8));
    EXPECT_EQ(core.stats().observations_applied, 7u);
    // The good contents were made durable at once; the damaged journal is kept beside.
    EXPECT_EQ(core.stats().snapshots, 1u);
    EXPECT_TRUE(std::filesystem::exists(dir / "map.journal.bad.1"));
    EXPECT_FALSE(core.degraded()) << core.degraded_reason();
    // The sender re-sends what it holds unacknowledged: 6 fills the hole, 7 and 8 are duplicates.
    for (std::uint64_t s = 6; s <= 8; ++s) core.apply(3, s, 0.0, scan(3, s), 6);
    EXPECT_EQ(core.acked(3), 8u);
    EXPECT_EQ(core.stats().duplicates, 2u);
  }
  MapServerCore core(config_in(dir.path()));
  EXPECT_TRUE(core.load_report().clean()) << core.load_report().summary();
  EXPECT_EQ(core.acked(3), 8u);
  // Applied in the order they arrived: 1..5, 7, 8, then 6.
  MapServerCore reference(config_in(dir / "reference"));
  for (std::uint64_t s : {1, 2, 3, 4, 5, 7, 8, 6}) reference.apply(3, s, 0.0, scan(3, s));
  expect_same_map(reference.map(), core.map());
}

TEST(MapServerCore, LocalizationModeFreezesTheMap) {
  TempDir dir;
  {
    MapServerCore core(config_in(dir.path()));
    core.apply(1, 1, 0.0, scan(1, 1));
    const PointMap frozen = core.map();
    const std::size_t records = core.stats().journal_records;
    core.set_mode("localization");
    EXPECT_EQ(core.mode(), "localization");
    for (std::uint64_t s = 2; s <= 4; ++s) {
      const auto r = core.apply(1, s, 0.0, scan(1, s + 10));
      EXPECT_FALSE(r.duplicate);
      EXPECT_FALSE(r.applied);
      EXPECT_EQ(r.inserted, 0u);
      EXPECT_EQ(r.acked, s);
    }
    expect_same_map(frozen, core.map());
    EXPECT_EQ(core.stats().journal_records, records);
    EXPECT_THROW(core.set_mode("painting"), std::invalid_argument);
    core.set_mode("mapping");
    EXPECT_TRUE(core.apply(1, 4, 0.0, scan(1, 14)).duplicate);  // acknowledged in localization
    // The sender holds nothing unacknowledged below 5 (fuse-update says so with every observation).
    EXPECT_TRUE(core.apply(1, 5, 0.0, scan(1, 15), 5).applied);
    EXPECT_EQ(core.acked(1), 5u);
  }
  // Started in localization by config: nothing changes either.
  MapServerConfig config = config_in(dir.path());
  config.policy.mode = "localization";
  MapServerCore core(config);
  const std::size_t points = core.map().num_points();
  EXPECT_EQ(core.acked(1), 5u) << "2..4 were settled by observation 5's lowest_unacked, journaled with it";
  EXPECT_FALSE(core.apply(1, 6, 0.0, scan(1, 20)).applied);
  EXPECT_EQ(core.map().num_points(), points);
}

TEST(MapServerCore, SaveToFileAndLoadReplaceTheMapAndBumpTheEpoch) {
  TempDir dir;
  const auto file = dir / "saved.snapshot";
  PointMap saved(1.0);
  {
    MapServerCore a(config_in(dir / "a"));
    feed(a, 1, 5);
    EXPECT_EQ(a.save(file), file);
    saved = a.map();
  }
  {
    MapServerCore b(config_in(dir / "b"));
    b.apply(99, 40, 0.0, scan(99, 40), 40);  // a session older than this map: 1..39 acknowledged elsewhere
    EXPECT_EQ(b.epoch(), 0u);
    const LoadReport report = b.load(file);
    EXPECT_TRUE(report.snapshot_ok);
    EXPECT_TRUE(report.clean()) << report.summary();
    EXPECT_EQ(b.epoch(), 1u);
    expect_same_map(saved, b.map());
    EXPECT_EQ(b.index().size(), saved.num_points());
    EXPECT_EQ(b.acked(99), 40u);  // acknowledgements never go back
    EXPECT_EQ(b.acked(11), 5u);   // the loaded map's sessions
    // A missing or unreadable file leaves everything as it was.
    const LoadReport missing = b.load(dir / "absent.snapshot");
    EXPECT_FALSE(missing.snapshot_ok);
    EXPECT_FALSE(missing.problems.empty());
    EXPECT_EQ(b.epoch(), 1u);
    expect_same_map(saved, b.map());
    b.apply(99, 41, 0.0, scan(99, 41), 41);
    saved = b.map();
  }
  // The replacement was durable: a restart serves the loaded map, its epoch and what followed.
  MapServerCore b(config_in(dir / "b"));
  EXPECT_TRUE(b.load_report().clean()) << b.load_report().summary();
  EXPECT_EQ(b.epoch(), 1u);
  expect_same_map(saved, b.map());
  EXPECT_EQ(b.acked(99), 41u);
}

TEST(MapServerCore, CorruptedChunkInTheSnapshotLosesOnlyThatChunk) {
  TempDir dir;
  PointMap before(1.0);
  {
    MapServerCore core(config_in(dir.path()));
    feed(core, 1, 6);
    core.save();
    before = core.map();
  }
  const auto snapshot = dir / MapStorage::kSnapshotName;
  const auto offsets = test::record_offsets(snapshot);
  ASSERT_GE(offsets.size(), 4u);
  test::flip_byte(snapshot, offsets[2] + 30);
  MapServerCore core(config_in(dir.path()));
  EXPECT_EQ(core.load_report().chunks_dropped, 1u);
  EXPECT_EQ(core.map().num_chunks(), before.num_chunks() - 1);
  EXPECT_EQ(core.acked(11), 6u);
  EXPECT_EQ(core.index().size(), core.map().num_points());
}

TEST(MapServerCore, TruncatedSnapshotKeepsItsGoodChunks) {
  TempDir dir;
  std::size_t chunks = 0;
  {
    MapServerCore core(config_in(dir.path()));
    feed(core, 1, 6);
    core.save();
    chunks = core.map().num_chunks();
  }
  const auto snapshot = dir / MapStorage::kSnapshotName;
  const auto offsets = test::record_offsets(snapshot);
  test::truncate_to(snapshot, offsets.back() + 5);
  MapServerCore core(config_in(dir.path()));
  EXPECT_TRUE(core.load_report().snapshot_ok);
  EXPECT_EQ(core.map().num_chunks(), chunks - 1);
  EXPECT_TRUE(test::mentions(core.load_report().problems, "truncated"));
}

TEST(MapServerCore, PointsThatCannotBeStoredAreRejected) {
  TempDir dir;
  MapServerCore core(config_in(dir.path()));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const auto r = core.apply(1, 1, 0.0, {{1, 1, 1}, {nan, 0, 0}, {0, 0, 1.0e30f}});
  EXPECT_TRUE(r.applied);
  EXPECT_EQ(r.rejected, 2u);
  EXPECT_EQ(r.inserted, 1u);
  EXPECT_EQ(core.map().num_points(), 1u);
}

TEST(MapServerCore, ReadOnlyOpensWithoutChangingTheDirectory) {
  TempDir dir;
  PointMap before(1.0);
  {
    MapServerCore core(config_in(dir.path()));
    feed(core, 1, 3);
    before = core.map();
  }
  MapServerCore reader(config_in(dir.path()), MapStorage::Access::kReadOnly);
  expect_same_map(before, reader.map());
  EXPECT_THROW(reader.apply(11, 4, 0.0, scan(11, 4)), std::logic_error);
  EXPECT_THROW(reader.save(), std::logic_error);
  EXPECT_FALSE(std::filesystem::exists(dir / MapStorage::kSnapshotName));
  reader.save(dir / "export.snapshot");  // to another file is fine
  EXPECT_TRUE(std::filesystem::exists(dir / "export.snapshot"));
}

TEST(MapServerConfig, LoadsValidatesAndRefusesUnknownKeys) {
  MapServerConfig config;
  ConfigNode node = ConfigNode::from_string(
      "directory: maps/site\nchunk_size: 25\nsnapshot_every: 50\nfsync: false\n"
      "max_pending_bytes: 33554432\nretry_interval_s: 0.5\n"
      "policy: {mode: localization, min_point_distance: 0.1}\nindex: {voxel_size: 0.4}\n");
  config.load(node);
  EXPECT_EQ(config.directory, "maps/site");
  EXPECT_EQ(config.chunk_size, 25.0);
  EXPECT_EQ(config.snapshot_every, 50u);
  EXPECT_FALSE(config.fsync);
  EXPECT_EQ(config.max_pending_bytes, 33554432u);
  EXPECT_EQ(config.retry_interval_s, 0.5);
  EXPECT_EQ(config.policy.mode, "localization");
  EXPECT_EQ(config.index.voxel_size, 0.4);
  EXPECT_EQ(config.index.max_voxels, MapServerConfig::kNoEviction);

  // Each refused with a message naming the key.
  const std::pair<const char*, const char*> bad[] = {
      {"chunk_size: 0\n", "chunk_size"},
      {"directory: ''\n", "directory"},
      {"index: {max_voxels: 5000}\n", "index.max_voxels"},
      {"journal: true\n", "journal"},
      {"policy: {mode: painting}\n", "mode"},
      {"max_pending_bytes: 1000\n", "max_pending_bytes"},
      {"max_pending_bytes: lots\n", "max_pending_bytes"},
      {"max_pending_bytes: -1\n", "max_pending_bytes"},
      {"retry_interval_s: 0\n", "retry_interval_s"},
      {"retry_interval_s: 1e9\n", "retry_interval_s"},
      {"retry_interval_s: .nan\n", "retry_interval_s"},
      {"policy: {carve_s: 2}\n", "carve_s"},  // observations carry no ray origins
      {"policy: {carve_lookback_s: 1}\n", "carve_lookback_s"}};
  for (const auto& [text, key] : bad) {
    MapServerConfig c;
    ConfigNode n = ConfigNode::from_string(text);
    try {
      c.load(n);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
}

TEST(MapPolicy, ReportsTheInsertedPoints) {
  MapPolicyConfig cfg;
  cfg.min_point_distance = 0.25;
  auto index = make_spatial_index(SpatialIndexConfig{});
  index->insert({Eigen::Vector3f::Zero()});
  std::vector<Eigen::Vector3f> inserted{{9, 9, 9}};
  make_map_policy(cfg)->apply(0.0, {{0.1f, 0, 0}, {1, 0, 0}, {0, 2, 0}}, *index, nullptr, &inserted);
  ASSERT_EQ(inserted.size(), 2u);
  EXPECT_EQ(inserted[0], Eigen::Vector3f(1, 0, 0));
  EXPECT_EQ(inserted[1], Eigen::Vector3f(0, 2, 0));
  cfg.mode = "localization";
  make_map_policy(cfg)->apply(0.0, {{5, 5, 5}}, *index, nullptr, &inserted);
  EXPECT_TRUE(inserted.empty());
}

}  // namespace
}  // namespace fuse

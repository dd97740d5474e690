// The map server core under real disk faults and damage (map_server_core.hpp, "Degraded"):
// a small tmpfs filled to its last page or remounted read-only, before the start and while
// running; acknowledged means durable and contiguous; what could not be written is kept pending
// in arrival order, bounded, and journaled once writing works again; damaged journals lose only
// what is damaged; a restart reconstructs the acknowledgements, holes included. The persisted map
// is read back from disk by a read-only MapServerCore and compared with a run without the fault.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core_fixtures.hpp"
#include "test_files.hpp"
#include "tmpfs_mount.hpp"

namespace fuse {
namespace {

using test::config_in;
using test::expect_same_map;
using test::scan;
using test::Sender;
using test::TempDir;
using test::TmpfsMount;

constexpr std::size_t kDiskBytes = std::size_t{1} << 20;
/// Most retry() calls a recovery may take (each journals up to a batch of pending observations).
constexpr int kMaxRetries = 50;

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/// Calls retry() until the core is running again (at most kMaxRetries); true when it is.
bool retry_until_running(MapServerCore& core, std::vector<Sender*> senders) {
  for (int i = 0; i < kMaxRetries && core.degraded(); ++i) {
    core.retry();
    for (Sender* s : senders) s->poll();
  }
  return !core.degraded();
}

/// Every acknowledged sequence the sender saw is durable in `persisted` (all below it too), and
/// acknowledgements only grew.
void expect_acks_durable(const Sender& sender, const MapServerCore& persisted) {
  std::uint64_t previous = 0;
  for (const std::uint64_t acked : sender.acks_seen()) {
    EXPECT_GE(acked, previous) << "an acknowledgement went back";
    previous = acked;
  }
  for (std::uint64_t q = 1; q <= sender.acked(); ++q) {
    ASSERT_TRUE(persisted.session_acks().covered(sender.session(), q))
        << "session " << sender.session() << " sequence " << q << " acknowledged but not on disk";
  }
  EXPECT_GE(persisted.acked(sender.session()), sender.acked());
}

/// A test on a small tmpfs: a real disk to fill or remount read-only (skipped, saying why,
/// where mounting is not permitted). config_ is a map directory on it.
class MapOnTmpfs : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!disk_.ok()) GTEST_SKIP() << disk_.why();
  }
  TempDir dir_;
  TmpfsMount disk_{dir_ / "disk", kDiskBytes};
  MapServerConfig config_ = config_in(disk_.path() / "map");
};

/// The persisted map holds the reference's points within 2 % (count and shared points).
void expect_within_two_percent(const PointMap& map, const PointMap& reference) {
  const double size_ratio = static_cast<double>(map.num_points()) / static_cast<double>(reference.num_points());
  EXPECT_NEAR(size_ratio, 1.0, 0.02) << map.num_points() << " points, the run without the fault " << reference.num_points();
  EXPECT_GE(test::shared_fraction(map, reference), 0.98);
  EXPECT_GE(test::shared_fraction(reference, map), 0.98);
}

// ---- full disk --------------------------------------------------------------------------------

TEST_F(MapOnTmpfs, FullDiskKeepsObservationsPendingAndJournalsThemInOrderOnceThereIsSpace) {
  config_.snapshot_every = 25;
  constexpr std::uint64_t kBefore = 30, kDuring = 60, kAfter = 10;
  {
    MapServerCore core(config_);
    Sender a(core, 11), b(core, 22);
    for (std::uint64_t i = 0; i < kBefore; ++i) {
      a.send_next();
      b.send_next();
    }
    ASSERT_EQ(a.acked(), kBefore);
    ASSERT_EQ(b.acked(), kBefore);
    const std::size_t journal_before = core.stats().journal_records;
    const std::size_t points_before = core.map().num_points();

    ASSERT_GT(disk_.fill(), 0u);
    std::size_t changed_chunks = 0;
    for (std::uint64_t i = 0; i < kDuring; ++i) {
      const MapApplyResult ra = a.send_next(), rb = b.send_next();
      EXPECT_TRUE(ra.pending);
      EXPECT_TRUE(rb.pending);
      changed_chunks += ra.changed_chunks.size() + rb.changed_chunks.size();
    }
    // Served while pending (a replica rebuilt now has them), though not acknowledged.
    EXPECT_GT(core.map().num_points(), points_before);
    EXPECT_GT(changed_chunks, 0u);
    // Degraded, nothing new acknowledged, everything kept in arrival order and counted.
    EXPECT_TRUE(core.degraded());
    EXPECT_TRUE(contains(core.degraded_reason(), "No space left on device")) << core.degraded_reason();
    EXPECT_EQ(a.acked(), kBefore);
    EXPECT_EQ(b.acked(), kBefore);
    MapServerStats stats = core.stats();
    EXPECT_EQ(stats.pending, 2 * kDuring);
    EXPECT_GT(stats.pending_bytes, 2 * kDuring * 400 * sizeof(Eigen::Vector3f));
    EXPECT_EQ(stats.counters["observations_deferred"], 2 * kDuring);
    EXPECT_EQ(stats.counters["journal_errors"], 1u) << "one failed write; the rest waits for the retry";
    EXPECT_EQ(stats.journal_records, journal_before) << "the journal is as it was";
    EXPECT_EQ(stats.observations_applied, 2 * kBefore);

    // Re-sends of pending observations are duplicates: nothing is kept twice.
    a.resend_all();
    EXPECT_EQ(core.stats().pending, 2 * kDuring);
    EXPECT_EQ(core.stats().duplicates, kDuring);

    // Retrying while the disk_ is still full changes nothing.
    core.retry();
    a.poll();
    EXPECT_TRUE(core.degraded());
    EXPECT_EQ(a.acked(), kBefore);
    EXPECT_EQ(core.stats().counters.at("journal_errors"), 2u);

    // Space again: journaled in arrival order, applied and acknowledged.
    disk_.remove();
    ASSERT_TRUE(retry_until_running(core, {&a, &b})) << core.degraded_reason();
    EXPECT_EQ(a.acked(), kBefore + kDuring);
    EXPECT_EQ(b.acked(), kBefore + kDuring);
    stats = core.stats();
    EXPECT_EQ(stats.pending, 0u);
    EXPECT_EQ(stats.observations_applied, 2 * (kBefore + kDuring));
    EXPECT_EQ(stats.snapshots, 3u) << "two before the fault (every 25 records), one due after it";
    for (std::uint64_t i = 0; i < kAfter; ++i) {
      EXPECT_TRUE(a.send_next().applied);
      EXPECT_TRUE(b.send_next().applied);
    }
    ASSERT_EQ(a.acked(), kBefore + kDuring + kAfter);

    // The map from disk_ (read-only, as an export tool reads it) against a run without the fault
    // that received the same observations in the same order.
    MapServerCore persisted(config_, MapStorage::Access::kReadOnly);
    EXPECT_TRUE(persisted.load_report().clean()) << persisted.load_report().summary();
    expect_acks_durable(a, persisted);
    expect_acks_durable(b, persisted);
    MapServerCore reference(config_in(dir_ / "reference"));
    Sender ra(reference, 11), rb(reference, 22);
    for (std::uint64_t i = 0; i < kBefore + kDuring + kAfter; ++i) {
      ra.send_next();
      rb.send_next();
    }
    expect_within_two_percent(persisted.map(), reference.map());
    expect_same_map(persisted.map(), reference.map());  // arrival order kept: in fact identical
  }
}

// fuse-map and the fuse-update that sent them killed together while the disk is full: with a
// spill directory on another file system the pending observations survive the server (taken back
// at start-up, journaled and acknowledged once there is space, the spill then emptied); without
// one they are gone (their sender is gone too).
TEST_F(MapOnTmpfs, PendingObservationsInTheSpillDirectorySurviveARestartOfTheServer) {
  constexpr std::uint64_t kBefore = 10, kDuring = 20;
  for (const bool spill : {true, false}) {
    SCOPED_TRACE(spill ? "with a spill directory" : "without");
    disk_.remove();
    std::filesystem::remove_all(config_.directory);
    MapServerConfig config = config_;
    if (spill) config.spill_directory = (dir_ / "spill").string();
    std::filesystem::remove_all(dir_ / "spill");
    {
      MapServerCore core(config);
      Sender a(core, spill ? 31 : 32);
      for (std::uint64_t i = 0; i < kBefore; ++i) a.send_next();
      ASSERT_GT(disk_.fill(), 0u);
      for (std::uint64_t i = 0; i < kDuring; ++i) EXPECT_TRUE(a.send_next().pending);
    }  // the server ends with 20 observations pending; their sender is not asked again
    disk_.remove();
    const std::uint64_t session = spill ? 31 : 32;
    {
      MapServerCore restarted(config);
      if (!spill) {
        EXPECT_FALSE(restarted.degraded());
        EXPECT_EQ(restarted.acked(session), kBefore);
        continue;
      }
      EXPECT_EQ(restarted.stats().pending, kDuring) << "taken back from the spill directory";
      ASSERT_TRUE(retry_until_running(restarted, {})) << restarted.degraded_reason();
      EXPECT_EQ(restarted.acked(session), kBefore + kDuring);
      EXPECT_EQ(restarted.stats().observations_applied, kBefore + kDuring);
    }
    // Emptied once journaled: the next start takes nothing back and has the same map.
    MapServerCore third(config);
    EXPECT_EQ(third.stats().pending, 0u);
    EXPECT_FALSE(third.degraded());
    EXPECT_EQ(third.acked(session), kBefore + kDuring);
  }
}

TEST_F(MapOnTmpfs, PendingBeyondItsBoundDropsTheOldestWhichStaysUnacknowledgedUntilSentAgain) {
  constexpr std::size_t kKept = 10;
  config_.max_pending_bytes = kKept * (sizeof(MapObservation) + scan(1, 1).size() * sizeof(Eigen::Vector3f));
  MapServerCore core(config_);
  Sender s(core, 9);
  for (int i = 0; i < 10; ++i) s.send_next();
  ASSERT_GT(disk_.fill(), 0u);
  for (int i = 0; i < 30; ++i) s.send_next();  // 11..40: 11..30 dropped from memory, 31..40 kept
  MapServerStats stats = core.stats();
  EXPECT_EQ(stats.pending, kKept);
  EXPECT_EQ(stats.counters["pending_dropped"], 20u);
  EXPECT_EQ(s.acked(), 10u);

  disk_.remove();
  ASSERT_TRUE(retry_until_running(core, {&s})) << core.degraded_reason();
  // 31..40 are durable now, above the hole 11..30: not acknowledged.
  EXPECT_EQ(s.acked(), 10u) << "the acknowledgement must not jump over what was dropped";
  EXPECT_TRUE(core.session_acks().covered(9, 40));
  EXPECT_EQ(core.session_acks().missing(9), 20u);
  // The sender still holds 11..40 and sends them again: the hole fills, all is acknowledged.
  s.resend_all();
  EXPECT_EQ(s.acked(), 40u);
  MapServerCore persisted(config_, MapStorage::Access::kReadOnly);
  expect_acks_durable(s, persisted);
}

TEST_F(MapOnTmpfs, FailedWriteLeavesTheJournalConsistent) {
  const auto journal = disk_.path() / "map" / MapStorage::kJournalName;
  constexpr int kLarge = 2000;  // 24 kB of points: more than the space left
  {
    MapServerCore core(config_);
    for (std::uint64_t q = 1; q <= 5; ++q) core.apply(4, q, 0.0, scan(4, q));
    const auto size = std::filesystem::file_size(journal);
    // Full, then two pages free: the record's first bytes fit, the rest does not (a short write).
    const std::uint64_t filled = disk_.fill();
    ASSERT_GT(filled, 8192u);
    std::filesystem::resize_file(disk_.path() / "filler", filled - 8192);
    const MapApplyResult r = core.apply(4, 6, 0.0, scan(4, 6, kLarge));
    EXPECT_TRUE(r.pending);
    EXPECT_EQ(r.acked, 5u);
    EXPECT_EQ(std::filesystem::file_size(journal), size) << "the torn record was rolled back";
    disk_.remove();
    ASSERT_TRUE(retry_until_running(core, {})) << core.degraded_reason();
    EXPECT_EQ(core.acked(4), 6u);
  }
  MapServerCore reloaded(config_, MapStorage::Access::kReadOnly);
  EXPECT_TRUE(reloaded.load_report().clean()) << reloaded.load_report().summary();
  EXPECT_EQ(reloaded.load_report().journal_records, 6u);
  EXPECT_EQ(reloaded.acked(4), 6u);
}

TEST_F(MapOnTmpfs, SnapshotThatDoesNotFitIsRetriedWhileTheJournalKeepsAcknowledging) {
  MapServerCore core(config_);
  Sender s(core, 2);
  for (int i = 0; i < 40; ++i) s.send_next();
  // Room for a few journal records, not for a snapshot of the whole map.
  const std::uint64_t filled = disk_.fill();
  std::filesystem::resize_file(disk_.path() / "filler", filled - 8 * 4096);
  EXPECT_THROW(core.save(), MapStorageError);
  EXPECT_TRUE(core.degraded());
  EXPECT_TRUE(contains(core.degraded_reason(), "snapshot")) << core.degraded_reason();
  EXPECT_FALSE(std::filesystem::exists(disk_.path() / "map" / "map.snapshot.tmp")) << "the temp file is removed";
  EXPECT_TRUE(s.send_next().applied) << "the journal still works: durable, acknowledged";
  EXPECT_EQ(s.acked(), 41u);
  core.retry();
  EXPECT_TRUE(core.degraded()) << "the snapshot still does not fit";
  disk_.remove();
  ASSERT_TRUE(retry_until_running(core, {&s})) << core.degraded_reason();
  EXPECT_EQ(core.stats().journal_records, 0u) << "the snapshot was written, the journal restarted";
  MapServerCore persisted(config_, MapStorage::Access::kReadOnly);
  expect_same_map(core.map(), persisted.map());
  expect_acks_durable(s, persisted);
}

// ---- read-only file system ------------------------------------------------------------------------

TEST_F(MapOnTmpfs, ReadOnlyDirectoryAtStartIsServedDegradedUntilItCanBeWritten) {
  PointMap before(1.0);
  {
    MapServerCore core(config_);
    Sender s(core, 5);
    for (int i = 0; i < 20; ++i) s.send_next();
    before = core.map();
  }
  ASSERT_TRUE(disk_.set_read_only(true)) << disk_.why();
  MapServerCore core(config_);  // not an error: serves what is there
  EXPECT_TRUE(core.degraded());
  EXPECT_TRUE(contains(core.degraded_reason(), "Read-only file system")) << core.degraded_reason();
  expect_same_map(before, core.map());
  EXPECT_EQ(core.acked(5), 20u);
  EXPECT_EQ(core.recent_sessions(4), (std::vector<std::pair<std::uint64_t, std::uint64_t>>{{5, 20}}));
  Sender s(core, 5, 20);
  for (int i = 0; i < 10; ++i) EXPECT_TRUE(s.send_next().pending);
  EXPECT_EQ(s.acked(), 20u);
  core.retry();
  EXPECT_TRUE(core.degraded());
  EXPECT_GE(core.stats().counters["write_retries_failed"], 1u);

  ASSERT_TRUE(disk_.set_read_only(false)) << disk_.why();
  ASSERT_TRUE(retry_until_running(core, {&s})) << core.degraded_reason();
  EXPECT_EQ(s.acked(), 30u);
  MapServerCore persisted(config_, MapStorage::Access::kReadOnly);
  expect_same_map(core.map(), persisted.map());
  expect_acks_durable(s, persisted);
}

TEST_F(MapOnTmpfs, RemountedReadOnlyWhileRunningRecoversAfterRemountingReadWrite) {
  MapServerCore core(config_);
  Sender s(core, 8);
  for (int i = 0; i < 10; ++i) s.send_next();
  // The core holds no file open for writing between writes, so the remount is allowed.
  ASSERT_TRUE(disk_.set_read_only(true, std::chrono::milliseconds(100))) << disk_.why();
  for (int i = 0; i < 10; ++i) EXPECT_TRUE(s.send_next().pending);
  EXPECT_TRUE(contains(core.degraded_reason(), "Read-only file system")) << core.degraded_reason();
  EXPECT_EQ(s.acked(), 10u);
  ASSERT_TRUE(disk_.set_read_only(false)) << disk_.why();
  ASSERT_TRUE(retry_until_running(core, {&s})) << core.degraded_reason();
  EXPECT_EQ(s.acked(), 20u);
  MapServerCore persisted(config_, MapStorage::Access::kReadOnly);
  expect_acks_durable(s, persisted);
}

TEST(MapDurability, UnwritableDirectoryStartsDegradedButALockedOneIsAConflict) {
  TempDir dir;
  std::ofstream(dir / "a_file") << "x";
  MapServerCore unwritable(config_in(dir / "a_file" / "map"));
  EXPECT_TRUE(unwritable.degraded());
  EXPECT_TRUE(contains(unwritable.degraded_reason(), "cannot create map directory")) << unwritable.degraded_reason();
  EXPECT_TRUE(unwritable.apply(1, 1, 0.0, scan(1, 1)).pending);
  EXPECT_EQ(unwritable.acked(1), 0u);

  MapServerCore first(config_in(dir / "map"));
  EXPECT_THROW(MapServerCore(config_in(dir / "map")), MapDirectoryLocked);
}

// ---- damage -----------------------------------------------------------------------------------

TEST(MapDurability, JournalWithFlippedBytesInTheMiddleKeepsEveryLaterRecord) {
  TempDir dir;
  constexpr std::uint64_t kRecords = 284, kSession = 17;
  constexpr int kPoints = 50;
  const MapServerConfig config = config_in(dir / "map");
  {
    MapServerCore core(config);
    for (std::uint64_t q = 1; q <= kRecords; ++q) core.apply(kSession, q, 0.0, scan(kSession, q, kPoints));
  }
  const auto journal = dir / "map" / MapStorage::kJournalName;
  const auto offsets = test::record_offsets(journal);
  ASSERT_EQ(offsets.size(), kRecords);
  // 64 bytes flipped in the middle of the file; which records they touch.
  const std::uint64_t from = std::filesystem::file_size(journal) / 2, to = from + 64;
  for (std::uint64_t at = from; at < to; ++at) test::flip_byte(journal, at);
  std::vector<std::uint64_t> damaged;  // sequences
  for (std::size_t i = 0; i < offsets.size(); ++i) {
    const std::uint64_t end = i + 1 < offsets.size() ? offsets[i + 1] : std::filesystem::file_size(journal);
    if (offsets[i] < to && end > from) damaged.push_back(i + 1);
  }
  ASSERT_FALSE(damaged.empty());

  // Read-only first (nothing on disk changes), then as the server opens it.
  for (const auto access : {MapStorage::Access::kReadOnly, MapStorage::Access::kReadWrite}) {
    MapServerCore core(config, access);
    const LoadReport& report = core.load_report();
    EXPECT_EQ(report.journal_records, kRecords - damaged.size()) << report.summary();
    EXPECT_EQ(report.journal_records_lost, damaged.size());
    ASSERT_EQ(report.damaged.size(), 1u);
    EXPECT_EQ(report.damaged[0].offset, offsets[damaged.front() - 1]);
    EXPECT_EQ(report.damaged[0].offset + report.damaged[0].bytes, offsets[damaged.back()]);
    EXPECT_TRUE(test::mentions(report.problems, "byte " + std::to_string(offsets[damaged.front() - 1])))
        << report.problems.at(0);
    EXPECT_TRUE(test::mentions(report.problems, "reading resumes at byte " + std::to_string(offsets[damaged.back()])));
    EXPECT_TRUE(contains(report.summary(), "1 damaged range")) << report.summary();
    EXPECT_EQ(core.acked(kSession), damaged.front() - 1);
    for (std::uint64_t q = damaged.back() + 1; q <= kRecords; ++q) {
      ASSERT_TRUE(core.session_acks().covered(kSession, q)) << "record " << q << " after the damage was lost";
    }
  }
  // The server made the good part durable in a snapshot; the damaged journal is kept beside.
  EXPECT_TRUE(std::filesystem::exists(dir / "map" / "map.journal.bad.1"));
  MapServerCore again(config);
  EXPECT_TRUE(again.load_report().clean()) << again.load_report().summary();
  EXPECT_EQ(again.acked(kSession), damaged.front() - 1);
  EXPECT_EQ(again.session_acks().missing(kSession), damaged.size());
}

TEST(MapDurability, RestartReconstructsAcknowledgementsAboveHolesAndFromLowestUnacked) {
  for (const std::size_t snapshot_every : {std::size_t{0}, std::size_t{3}}) {
    SCOPED_TRACE("snapshot_every " + std::to_string(snapshot_every));
    TempDir dir;
    const MapServerConfig config = config_in(dir / "map", snapshot_every);
    std::map<std::uint64_t, std::uint64_t> acked;
    {
      MapServerCore core(config);
      for (const std::uint64_t q : {1, 2, 4, 5}) core.apply(1, q, 0.0, scan(1, q));  // 3 never arrives
      // A session older than this map: its sender says it holds nothing below 100.
      for (std::uint64_t q = 100; q <= 103; ++q) core.apply(2, q, 0.0, scan(2, q), 100);
      EXPECT_EQ(core.acked(1), 2u);
      EXPECT_EQ(core.acked(2), 103u);
      acked = core.acked_sequences();
    }
    MapServerCore core(config);
    EXPECT_TRUE(core.load_report().clean()) << core.load_report().summary();
    EXPECT_EQ(core.acked_sequences(), acked);
    EXPECT_TRUE(core.session_acks().covered(1, 5));
    EXPECT_FALSE(core.session_acks().covered(1, 3));
    EXPECT_EQ(core.recent_sessions(16), (std::vector<std::pair<std::uint64_t, std::uint64_t>>{{2, 103}, {1, 2}}));
    EXPECT_TRUE(core.apply(1, 3, 0.0, scan(1, 3)).applied);
    EXPECT_EQ(core.acked(1), 5u) << "the hole filled: acknowledged through what was durable above it";
    EXPECT_TRUE(core.apply(1, 4, 0.0, scan(1, 4)).duplicate);
  }
}

}  // namespace
}  // namespace fuse

#include "fuse/map/map_server_core.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <sstream>
#include <stdexcept>

#include "fuse/core/logging.hpp"

namespace fuse {

namespace {
/// Smallest iVox capacity accepted for the server's index (it must never evict).
constexpr std::size_t kMinServerVoxels = std::size_t{1} << 24;
/// Longest retry interval accepted: a degraded server should try again within minutes.
constexpr double kMaxRetryIntervalS = 600.0;

std::string id(std::uint64_t session, std::uint64_t sequence) {
  return std::to_string(session) + ":" + std::to_string(sequence);
}

/// Seconds as a person writes them ("2", "0.5").
std::string seconds(double s) {
  std::ostringstream out;
  out << s;
  return out.str();
}
}  // namespace

SpatialIndexConfig MapServerConfig::default_index() {
  SpatialIndexConfig index;
  index.max_voxels = kNoEviction;
  return index;
}

void MapServerConfig::load(ConfigNode& node) {
  node.get("directory", directory).get("chunk_size", chunk_size).get("snapshot_every", snapshot_every);
  node.get("fsync", fsync).get("max_pending_bytes", max_pending_bytes).get("retry_interval_s", retry_interval_s);
  node.get("spill_directory", spill_directory).get("saved_directory", saved_directory);
  load_section(node, "policy", policy);
  load_section(node, "index", index);
  node.check(!directory.empty(), "directory", "must be set");
  // An observation carries its points, not where each ray started: the server cannot carve.
  node.check(policy.carve_s == 0.0, "policy.carve_s",
             "must be 0: the map server does not carve free space (its observations carry no ray origins); "
             "carving runs in the estimator (estimator.map.carve_s)");
  node.check(policy.carve_lookback_s == 0.0, "policy.carve_lookback_s",
             "must be 0: the map server sees no rays to look back on; fuse-update leaves moving points out of "
             "the observations it publishes (estimator.map.carve_lookback_s)");
  // With a trailing separator on both, "map", "./map" and "map/" compare equal.
  node.check((std::filesystem::path(saved_directory) / "").lexically_normal() !=
                 (std::filesystem::path(directory) / "").lexically_normal(),
             "saved_directory", "must not be the map directory (its live snapshot and journal)");
  node.check(std::isfinite(chunk_size) && chunk_size >= 1.0 && chunk_size <= 1000.0, "chunk_size",
             "must be in [1, 1000] m");
  node.check(index.max_voxels >= kMinServerVoxels, "index.max_voxels",
             "must be at least " + std::to_string(kMinServerVoxels) + ": the map server's index never evicts");
  node.check(max_pending_bytes >= kMinPendingBytes, "max_pending_bytes",
             "must be at least " + std::to_string(kMinPendingBytes) + " bytes (a few of the largest observations)");
  node.check(std::isfinite(retry_interval_s) && retry_interval_s > 0.0 && retry_interval_s <= kMaxRetryIntervalS,
             "retry_interval_s", "must be in (0, " + std::to_string(static_cast<int>(kMaxRetryIntervalS)) + "] s");
  node.finish();
}

std::filesystem::path MapServerConfig::saved_maps() const {
  return saved_directory.empty() ? std::filesystem::path(directory) / "saved" : std::filesystem::path(saved_directory);
}

MapServerCore::MapServerCore(const MapServerConfig& config, MapStorage::Access access)
    : config_(config), access_(access), map_(config.chunk_size), counters_(logger("map")) {
  if (config_.policy.mode != "mapping" && config_.policy.mode != "localization") {
    throw ConfigError("map_server.policy.mode: must be mapping or localization");
  }
  MapPolicyConfig mapping_config = config_.policy;
  mapping_config.mode = "mapping";
  mapping_ = make_map_policy(mapping_config);
  index_ = make_spatial_index(config_.index);

  auto log = logger("map");
  storage_ = std::make_unique<MapStorage>(config_.directory, config_.fsync, access_);
  // The snapshot's points go into the index before the journal replays on top of them.
  bool index_built = false;
  load_report_ = storage_->load(map_, meta_, [&](const MapObservation& o) {
    if (!index_built) {
      rebuild_index();
      index_built = true;
    }
    std::size_t inserted = 0;
    apply_points(o.t, o.points, inserted);
  });
  if (!index_built) rebuild_index();
  meta_.mode = config_.policy.mode;
  meta_.min_point_distance = config_.policy.min_point_distance;
  meta_.system_name = config_.system_name;

  for (const std::string& problem : load_report_.problems) log->warn("{}", problem);
  if (map_.chunk_size() != config_.chunk_size) {
    log->info("chunk size {} m from the snapshot (configured {} m applies to new maps only)", map_.chunk_size(),
              config_.chunk_size);
  }
  log->info("map {}: {} points in {} chunks, epoch {}, mode {} ({})", config_.directory, map_.num_points(),
            map_.num_chunks(), meta_.epoch, meta_.mode, load_report_.summary());
  if (access_ != MapStorage::Access::kReadWrite) return;
  open_spill();
  if (!storage_->writable()) {
    log->error("map directory {} cannot be written ({}): serving what it holds, acknowledging nothing new, "
               "trying again every {} s",
               config_.directory, storage_->write_error(), config_.retry_interval_s);
  }
  // Damage found: make the good contents durable in a fresh snapshot (the damaged file is kept).
  snapshot_wanted_ = storage_->damaged();
  if (snapshot_wanted_ && storage_->writable()) try_snapshot("after a damaged load");
}

void MapServerCore::rebuild_index() {
  index_ = make_spatial_index(config_.index);
  map_.for_each_chunk([&](const PointChunk& chunk) { index_->insert(chunk.points); });
}

std::vector<std::uint64_t> MapServerCore::apply_points(double t, const std::vector<Eigen::Vector3f>& points,
                                                       std::size_t& inserted) {
  mapping_->apply(t, points, *index_, nullptr, &inserted_);
  inserted = inserted_.size();
  return map_.insert(inserted_);
}

std::vector<std::uint64_t> MapServerCore::apply_durable(const MapObservation& o, std::size_t& inserted) {
  std::vector<std::uint64_t> changed = apply_points(o.t, o.points, inserted);
  meta_.acks.add_durable(o.session, o.sequence);
  ++meta_.observations;
  return changed;
}

bool MapServerCore::duplicate(std::uint64_t session, std::uint64_t sequence) const {
  return meta_.acks.covered(session, sequence) || pending_ids_.count({session, sequence}) > 0;
}

MapApplyResult MapServerCore::apply(std::uint64_t session, std::uint64_t sequence, double t,
                                    const std::vector<Eigen::Vector3f>& points, std::uint64_t lowest_unacked) {
  if (access_ != MapStorage::Access::kReadWrite) throw std::logic_error("MapServerCore::apply on a read-only map");
  if (session == 0 || sequence == 0 || lowest_unacked > sequence) {
    throw std::invalid_argument("MapServerCore::apply: observation " + id(session, sequence) + " with lowest_unacked " +
                                std::to_string(lowest_unacked) + " (session and sequence from 1, lowest_unacked at most the sequence)");
  }
  ++received_;
  MapApplyResult result;
  // What the sender gave up is settled, whatever happens to this observation.
  meta_.acks.raise_floor(session, lowest_unacked);
  meta_.acks.touch(session);
  if (duplicate(session, sequence)) {
    ++duplicates_;
    result.duplicate = true;
    result.acked = acked(session);
    return result;
  }
  if (meta_.mode == "localization") {
    // Settled without a write: the frozen map does not take it, now or later.
    meta_.acks.add_durable(session, sequence);
    result.acked = acked(session);
    return result;
  }

  MapObservation observation{session, sequence, t, {}, lowest_unacked};
  observation.points.reserve(points.size());
  for (const Eigen::Vector3f& p : points) {
    if (map_.insertable(p)) observation.points.push_back(p);
  }
  result.rejected = points.size() - observation.points.size();
  // In arrival order: while anything is pending, new observations queue behind it.
  if (pending_.empty() && storage_->writable()) {
    if (storage_->append({&observation}) == 1) {
      result.applied = true;
      result.changed_chunks = apply_durable(observation, result.inserted);
      result.acked = acked(session);
      if (config_.snapshot_every > 0 && storage_->journal_records() >= config_.snapshot_every &&
          snapshot_error_.empty()) {
        // The observation is already durable in the journal: a failed snapshot does not undo it.
        try_snapshot("automatic");
      }
      return result;
    }
    journal_failed(observation);
  }
  result.changed_chunks = keep_pending(std::move(observation), result.inserted);
  result.pending = true;
  result.acked = acked(session);
  return result;
}

bool MapServerCore::note_gravity(const Eigen::Vector3d& g, double max_tilt) {
  if (!g.allFinite() || g.norm() < 0.5) return false;
  const Eigen::Vector3d d = g.normalized();
  if (std::acos(std::clamp(-d.z(), -1.0, 1.0)) > max_tilt) return false;
  if (!meta_.gravity && meta_.mode == "mapping") meta_.gravity = d;
  return true;
}

void MapServerCore::journal_failed(const MapObservation& o) {
  counters_.count("journal_errors", "observation " + id(o.session, o.sequence) + " not journaled: " +
                                        storage_->write_error() + "; kept in memory, not acknowledged, writing again every " +
                                        seconds(config_.retry_interval_s) + " s");
}

void MapServerCore::open_spill() {
  if (config_.spill_directory.empty()) return;
  auto log = logger("map");
  try {
    spill_ = std::make_unique<MapStorage>(config_.spill_directory, config_.fsync, MapStorage::Access::kReadWrite);
    PointMap unused(config_.chunk_size);
    MapMeta unused_meta;
    std::size_t taken = 0, already = 0;
    spill_->load(unused, unused_meta, [&](const MapObservation& o) {
      if (duplicate(o.session, o.sequence)) {
        ++already;  // journaled in the map directory before the previous instance ended
        return;
      }
      std::size_t inserted = 0;
      keep_pending(o, inserted, false);
      ++taken;
    });
    spill_dirty_ = taken + already > 0;
    if (spill_dirty_) {
      log->warn("spill directory {}: {} observations a previous instance could not journal taken back as pending "
                "({} were journaled already)",
                config_.spill_directory, taken, already);
    }
    if (pending_.empty()) clear_spill();
  } catch (const MapStorageError& e) {
    spill_.reset();
    counters_.count("spill_errors", "spill directory " + config_.spill_directory +
                                        " not usable: " + e.what() + "; pending observations are kept in memory only");
  }
}

void MapServerCore::clear_spill() {
  if (!spill_ || !spill_dirty_) return;
  try {
    spill_->snapshot(PointMap(config_.chunk_size), MapMeta{});  // an empty snapshot truncates its journal
    spill_dirty_ = false;
  } catch (const MapStorageError& e) {
    counters_.count("spill_errors", std::string("spill journal not emptied: ") + e.what());
  }
}

std::vector<std::uint64_t> MapServerCore::keep_pending(MapObservation observation, std::size_t& inserted, bool spill) {
  if (spill && spill_) {
    if (spill_->append({&observation}) == 1) {
      spill_dirty_ = true;
    } else {
      counters_.count("spill_errors", "observation " + id(observation.session, observation.sequence) +
                                          " not written to the spill directory: " + spill_->write_error() +
                                          "; kept in memory only");
      spill_->make_writable();
    }
  }
  // Served at once (the replicas of a fuse-update restarted meanwhile get it), acknowledged only
  // once journaled. Pending observations are journaled in arrival order and nothing is applied
  // between them, so the map is the one journal-then-apply would give.
  std::vector<std::uint64_t> changed = apply_points(observation.t, observation.points, inserted);
  const std::size_t bytes = sizeof(MapObservation) + observation.points.size() * sizeof(Eigen::Vector3f);
  pending_ids_.insert({observation.session, observation.sequence});
  const std::string name = id(observation.session, observation.sequence);
  pending_.push_back({std::move(observation), bytes});
  pending_bytes_ += bytes;
  counters_.count("observations_deferred",
                  "observation " + name + " kept in memory, not journaled (" + std::to_string(pending_.size()) +
                      " pending, " + std::to_string(pending_bytes_) + " bytes): " +
                      (storage_->writable() ? "behind earlier pending observations" : storage_->write_error()));
  // The bound: drop the oldest (its sender still holds it, unacknowledged, and sends it again).
  while (pending_bytes_ > config_.max_pending_bytes && pending_.size() > 1) {
    const MapObservation& oldest = pending_.front().observation;
    counters_.count("pending_dropped", "observation " + id(oldest.session, oldest.sequence) +
                                           " dropped from memory: pending observations over map_server.max_pending_bytes (" +
                                           std::to_string(config_.max_pending_bytes) + "); its sender still holds it");
    pending_ids_.erase({oldest.session, oldest.sequence});
    pending_bytes_ -= pending_.front().bytes;
    pending_.pop_front();
  }
  return changed;
}

bool MapServerCore::snapshot_due() const {
  return snapshot_wanted_ || !snapshot_error_.empty() ||
         (config_.snapshot_every > 0 && storage_->journal_records() >= config_.snapshot_every);
}

bool MapServerCore::try_snapshot(const char* why) {
  try {
    storage_->snapshot(map_, meta_);
  } catch (const MapStorageError& e) {
    snapshot_error_ = e.what();
    // A snapshot writes the whole map before it can fail for space: back off (1, 2, 4, ...
    // retries, at most kMaxSnapshotBackoff) instead of rewriting it at every retry.
    snapshot_backoff_ = std::min(kMaxSnapshotBackoff, std::max<std::size_t>(1, 2 * snapshot_backoff_));
    retries_to_snapshot_ = snapshot_backoff_;
    counters_.count("snapshot_errors", std::string(why) + " snapshot not written: " + e.what() +
                                           " (the journal keeps every acknowledged observation)");
    return false;
  }
  ++snapshots_;
  snapshot_wanted_ = false;
  snapshot_backoff_ = 0;
  retries_to_snapshot_ = 0;
  if (!snapshot_error_.empty()) logger("map")->info("{} snapshot written: snapshots work again", why);
  snapshot_error_.clear();
  return true;
}

MapRetryResult MapServerCore::retry() {
  MapRetryResult result;
  if (access_ != MapStorage::Access::kReadWrite) return result;
  auto log = logger("map");
  const bool was_unwritable = !storage_->writable();
  if (was_unwritable && !storage_->make_writable()) {
    counters_.count("write_retries_failed", "map directory " + config_.directory + " still cannot be written: " +
                                                storage_->write_error());
    return result;
  }
  if (!pending_.empty()) {
    // One batch, one fsync; in arrival order.
    std::vector<const MapObservation*> batch;
    std::size_t bytes = 0;
    for (const Pending& p : pending_) {
      if (batch.size() == kRetryBatchRecords || (!batch.empty() && bytes + p.bytes > kRetryBatchBytes)) break;
      batch.push_back(&p.observation);
      bytes += p.bytes;
    }
    const std::size_t written = storage_->append(batch);
    for (std::size_t i = 0; i < written; ++i) {
      const Pending& p = pending_.front();
      // Its points are in the map since it arrived: now it is durable, it is acknowledged.
      meta_.acks.add_durable(p.observation.session, p.observation.sequence);
      ++meta_.observations;
      pending_ids_.erase({p.observation.session, p.observation.sequence});
      pending_bytes_ -= p.bytes;
      pending_.pop_front();
    }
    result.journaled = written;
    if (was_unwritable && written > 0) {
      log->info("the journal takes records again ({} observations still pending)", pending_.size());
    }
    if (written < batch.size()) {
      journal_failed(pending_.front().observation);
      return result;
    }
    result.more = !pending_.empty();
    if (result.more) return result;
    log->info("every pending observation is journaled and acknowledged");
    clear_spill();
  }
  if (retries_to_snapshot_ > 0) --retries_to_snapshot_;
  if (snapshot_due() && retries_to_snapshot_ == 0) try_snapshot(snapshot_error_.empty() ? "due" : "retried");
  return result;
}

bool MapServerCore::degraded() const {
  return access_ == MapStorage::Access::kReadWrite &&
         (!storage_->writable() || !pending_.empty() || !snapshot_error_.empty());
}

std::string MapServerCore::degraded_reason() const {
  if (!degraded()) return {};
  std::string reason;
  if (!storage_->writable()) {
    reason = "not journaling: " + storage_->write_error();
  } else if (!snapshot_error_.empty()) {
    reason = "snapshot: " + snapshot_error_;
  } else {
    reason = "writing the pending observations";
  }
  if (!pending_.empty()) {
    reason += "; " + std::to_string(pending_.size()) + " pending (" + std::to_string(pending_bytes_) + " bytes)";
  }
  return reason;
}

std::uint64_t MapServerCore::acked(std::uint64_t session) const { return meta_.acks.acked(session); }

std::map<std::uint64_t, std::uint64_t> MapServerCore::acked_sequences() const {
  std::map<std::uint64_t, std::uint64_t> out;
  for (const auto& [session, state] : meta_.acks.sessions()) out[session] = state.acked;
  return out;
}

std::vector<std::pair<std::uint64_t, std::uint64_t>> MapServerCore::recent_sessions(std::size_t n) const {
  return meta_.acks.recent(n);
}

std::uint64_t MapServerCore::newest_session() const {
  const auto recent = meta_.acks.recent(1);
  return recent.empty() ? 0 : recent.front().first;
}

void MapServerCore::set_mode(const std::string& mode) {
  if (mode != "mapping" && mode != "localization") {
    throw std::invalid_argument("unknown map mode '" + mode + "' (mapping | localization)");
  }
  if (mode != meta_.mode) logger("map")->info("mode {} -> {}", meta_.mode, mode);
  meta_.mode = mode;
}

std::filesystem::path MapServerCore::save(const std::filesystem::path& file) {
  if (!file.empty()) {
    MapStorage::write_snapshot_file(file, map_, meta_, config_.fsync);
    logger("map")->info("saved {} points to {}", map_.num_points(), file.string());
    return file;
  }
  if (access_ != MapStorage::Access::kReadWrite) throw std::logic_error("MapServerCore::save into a read-only map");
  if (!pending_.empty()) {
    // A snapshot must not cover sequences that are journaled after it (load() would skip them).
    throw MapStorageError(std::to_string(pending_.size()) +
                          " observations are pending (not journaled yet): the map directory is snapshotted once "
                          "they are");
  }
  if (!try_snapshot("requested")) throw MapStorageError(snapshot_error_);
  return storage_->snapshot_path();
}

LoadReport MapServerCore::load(const std::filesystem::path& file) {
  if (access_ != MapStorage::Access::kReadWrite) throw std::logic_error("MapServerCore::load into a read-only map");
  if (degraded()) throw MapStorageError("degraded (" + degraded_reason() + "): the map is not replaced");
  auto log = logger("map");
  PointMap loaded(config_.chunk_size);
  MapMeta meta;
  LoadReport report = MapStorage::read_snapshot_file(file, loaded, meta);
  for (const std::string& problem : report.problems) log->warn("{}", problem);
  if (!report.snapshot_ok) {
    log->error("load {}: not loaded, the map is unchanged", file.string());
    return report;
  }
  // Acknowledgements never go back: keep every session's, whichever map it came from.
  meta.acks.merge(meta_.acks);
  meta.epoch = meta_.epoch + 1;
  meta.mode = meta_.mode;
  meta.min_point_distance = meta_.min_point_distance;
  meta.system_name = meta_.system_name;  // from now on this system's map
  // Durable first: a failure leaves the served map as it was.
  storage_->snapshot(loaded, meta);
  ++snapshots_;
  map_ = std::move(loaded);
  meta_ = std::move(meta);
  rebuild_index();
  log->info("loaded {}: {} points in {} chunks, epoch {}", file.string(), map_.num_points(), map_.num_chunks(),
            meta_.epoch);
  return report;
}

MapServerStats MapServerCore::stats() const {
  MapServerStats s;
  s.epoch = meta_.epoch;
  s.mode = meta_.mode;
  s.points = map_.num_points();
  s.chunks = map_.num_chunks();
  s.chunk_size = map_.chunk_size();
  s.observations_applied = meta_.observations;
  s.observations_received = received_;
  s.duplicates = duplicates_;
  s.journal_records = storage_->journal_records();
  s.snapshots = snapshots_;
  s.degraded = degraded();
  s.degraded_reason = degraded_reason();
  s.pending = pending_.size();
  s.pending_bytes = pending_bytes_;
  s.counters = counters_.map();
  return s;
}

}  // namespace fuse

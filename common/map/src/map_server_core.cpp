#include "fuse/map/map_server_core.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "fuse/core/logging.hpp"

namespace fuse {

namespace {
/// Smallest iVox capacity accepted for the server's index (it must never evict).
constexpr std::size_t kMinServerVoxels = std::size_t{1} << 24;
}  // namespace

SpatialIndexConfig MapServerConfig::default_index() {
  SpatialIndexConfig index;
  index.max_voxels = kNoEviction;
  return index;
}

void MapServerConfig::load(ConfigNode& node) {
  node.get("directory", directory).get("chunk_size", chunk_size).get("snapshot_every", snapshot_every);
  node.get("fsync", fsync);
  load_section(node, "policy", policy);
  load_section(node, "index", index);
  node.check(!directory.empty(), "directory", "must be set");
  node.check(std::isfinite(chunk_size) && chunk_size >= 1.0 && chunk_size <= 1000.0, "chunk_size",
             "must be in [1, 1000] m");
  node.check(index.max_voxels >= kMinServerVoxels, "index.max_voxels",
             "must be at least " + std::to_string(kMinServerVoxels) + ": the map server's index never evicts");
  node.finish();
}

MapServerCore::MapServerCore(const MapServerConfig& config, MapStorage::Access access)
    : config_(config), access_(access), map_(config.chunk_size) {
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
    apply_points(o.points, inserted);
  });
  if (!index_built) rebuild_index();
  meta_.mode = config_.policy.mode;
  meta_.min_point_distance = config_.policy.min_point_distance;
  acked_ = meta_.applied;

  for (const std::string& problem : load_report_.problems) log->warn("{}", problem);
  if (map_.chunk_size() != config_.chunk_size) {
    log->info("chunk size {} m from the snapshot (configured {} m applies to new maps only)", map_.chunk_size(),
              config_.chunk_size);
  }
  log->info("map {}: {} points in {} chunks, epoch {}, mode {} ({})", config_.directory, map_.num_points(),
            map_.num_chunks(), meta_.epoch, meta_.mode, load_report_.summary());
}

void MapServerCore::rebuild_index() {
  index_ = make_spatial_index(config_.index);
  map_.for_each_chunk([&](const PointChunk& chunk) { index_->insert(chunk.points); });
}

std::vector<std::uint64_t> MapServerCore::apply_points(const std::vector<Eigen::Vector3f>& points,
                                                       std::size_t& inserted) {
  mapping_->apply(points, *index_, nullptr, &inserted_);
  inserted = inserted_.size();
  return map_.insert(inserted_);
}

MapApplyResult MapServerCore::apply(std::uint64_t session, std::uint64_t sequence, double t,
                                    const std::vector<Eigen::Vector3f>& points) {
  if (access_ != MapStorage::Access::kReadWrite) throw std::logic_error("MapServerCore::apply on a read-only map");
  ++received_;
  MapApplyResult result;
  const auto it = acked_.find(session);
  if (it != acked_.end() && sequence <= it->second) {
    ++duplicates_;
    result.duplicate = true;
    result.acked = it->second;
    return result;
  }
  if (meta_.mode == "localization") {
    acked_[session] = sequence;
    result.acked = sequence;
    return result;
  }

  MapObservation observation{session, sequence, t, {}};
  observation.points.reserve(points.size());
  for (const Eigen::Vector3f& p : points) {
    if (map_.insertable(p)) observation.points.push_back(p);
  }
  result.rejected = points.size() - observation.points.size();
  storage_->append(observation);  // durable before anything changes; throws otherwise

  result.applied = true;
  result.changed_chunks = apply_points(observation.points, result.inserted);
  meta_.applied[session] = sequence;
  ++meta_.observations;
  acked_[session] = sequence;
  result.acked = sequence;

  if (config_.snapshot_every > 0 && storage_->journal_records() >= config_.snapshot_every) {
    // The observation is already durable in the journal: a failed snapshot does not undo it.
    try {
      save();
    } catch (const MapStorageError& e) {
      last_error_ = e.what();
      logger("map")->error("automatic snapshot failed: {}", e.what());
    }
  }
  return result;
}

std::uint64_t MapServerCore::acked(std::uint64_t session) const {
  const auto it = acked_.find(session);
  return it == acked_.end() ? 0 : it->second;
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
  storage_->snapshot(map_, meta_);
  ++snapshots_;
  last_error_.clear();
  return storage_->snapshot_path();
}

LoadReport MapServerCore::load(const std::filesystem::path& file) {
  if (access_ != MapStorage::Access::kReadWrite) throw std::logic_error("MapServerCore::load into a read-only map");
  auto log = logger("map");
  PointMap loaded(config_.chunk_size);
  MapMeta meta;
  LoadReport report = MapStorage::read_snapshot_file(file, loaded, meta);
  for (const std::string& problem : report.problems) log->warn("{}", problem);
  if (!report.snapshot_ok) {
    log->error("load {}: not loaded, the map is unchanged", file.string());
    return report;
  }
  // Acknowledgements never go back: keep every session's highest, whichever map it came from.
  for (const auto& [session, sequence] : meta_.applied) {
    std::uint64_t& s = meta.applied[session];
    s = std::max(s, sequence);
  }
  for (const auto& [session, sequence] : acked_) {
    std::uint64_t& s = meta.applied[session];
    s = std::max(s, sequence);
  }
  meta.epoch = meta_.epoch + 1;
  meta.mode = meta_.mode;
  meta.min_point_distance = meta_.min_point_distance;
  // Durable first: a failure leaves the served map as it was.
  storage_->snapshot(loaded, meta);
  ++snapshots_;
  map_ = std::move(loaded);
  meta_ = std::move(meta);
  acked_ = meta_.applied;
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
  s.last_error = last_error_;
  return s;
}

}  // namespace fuse

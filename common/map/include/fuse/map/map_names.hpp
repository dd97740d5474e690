// Names of saved maps, for the map server's control RPC (fuse-map-ctl save NAME | load NAME).
// Anyone on the bus may send a control request, so a request never carries a path: a name is a
// plain file name, resolved inside one directory of saved maps (map_server.saved_directory, by
// default DIR/saved beside the live map.snapshot and map.journal, which no name can reach). A
// request naming anything else is refused with one answer whatever lies at that path, so that the
// server cannot be used to write outside its directory nor to learn which files exist.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

namespace fuse {

/// Longest saved-map name accepted.
inline constexpr std::size_t kMaxMapNameLength = 128;

/// Why `name` is not a saved-map name (empty when it is one): 1–128 characters of letters,
/// digits, '.', '_' and '-', not starting with '.' (so never "..", a hidden file or a path).
std::string invalid_map_name(const std::string& name);

/// `saved_directory`/`name` when the name is valid; otherwise nullopt and `why` says what a name
/// must be.
std::optional<std::filesystem::path> resolve_map_name(const std::filesystem::path& saved_directory,
                                                      const std::string& name, std::string& why);

}  // namespace fuse

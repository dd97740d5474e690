#include "fuse/map/map_names.hpp"

#include "fuse/core/plain_name.hpp"

namespace fuse {

std::string invalid_map_name(const std::string& name) {
  const std::string rule = "a saved map's name is a file name of 1-" + std::to_string(kMaxMapNameLength) +
                           " letters, digits, '.', '_' or '-', not starting with '.'; paths are refused";
  if (name.empty() || name.size() > kMaxMapNameLength || name.front() == '.' || !has_only_plain_name_chars(name)) {
    return rule;
  }
  return {};
}

std::optional<std::filesystem::path> resolve_map_name(const std::filesystem::path& saved_directory,
                                                      const std::string& name, std::string& why) {
  why = invalid_map_name(name);
  if (!why.empty()) return std::nullopt;
  return saved_directory / name;
}

}  // namespace fuse

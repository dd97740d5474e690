#include "fuse/map/map_names.hpp"

namespace fuse {

std::string invalid_map_name(const std::string& name) {
  const std::string rule = "a saved map's name is a file name of 1-" + std::to_string(kMaxMapNameLength) +
                           " letters, digits, '.', '_' or '-', not starting with '.'; paths are refused";
  if (name.empty() || name.size() > kMaxMapNameLength || name.front() == '.') return rule;
  for (const char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '_' ||
                    c == '-';
    if (!ok) return rule;
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

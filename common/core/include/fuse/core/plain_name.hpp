// Names that travel into file names and DDS partitions: letters, digits, '.', '_' and '-' only
// (no separator, no wildcard, no quoting needed anywhere they are used).
#pragma once

#include <string>

namespace fuse {

inline bool is_plain_name_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
}

/// Every character of `name` is a plain-name character (true for an empty name).
inline bool has_only_plain_name_chars(const std::string& name) {
  for (const char c : name) {
    if (!is_plain_name_char(c)) return false;
  }
  return true;
}

}  // namespace fuse

// Config tests: each "key: value" text must be refused by a config section's load() with a
// ConfigError that names the key.
#pragma once

#include <gtest/gtest.h>

#include <initializer_list>
#include <string>

#include "fuse/core/config.hpp"

namespace fuse {

template <typename Section>
void expect_refused_naming_the_key(std::initializer_list<const char*> texts) {
  for (const char* text : texts) {
    ConfigNode node = ConfigNode::from_string(text);
    Section section;
    try {
      section.load(node);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const ConfigError& e) {
      const std::string key = std::string(text).substr(0, std::string(text).find(':'));
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
}

}  // namespace fuse

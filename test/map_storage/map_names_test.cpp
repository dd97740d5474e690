// Saved-map names (fuse/map/map_names.hpp): what a control request may name, and what it may not.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "fuse/map/map_names.hpp"
#include "fuse/map/map_server_core.hpp"

namespace fuse {
namespace {

TEST(MapNames, PlainFileNamesResolveInsideTheSavedDirectory) {
  for (const char* name : {"a", "saved.snapshot", "run_2026-11-27.snapshot", "map.journal", "A-1"}) {
    std::string why;
    const auto path = resolve_map_name("/srv/map/saved", name, why);
    ASSERT_TRUE(path) << name << ": " << why;
    EXPECT_EQ(*path, std::filesystem::path("/srv/map/saved") / name);
    EXPECT_TRUE(why.empty());
  }
}

TEST(MapNames, PathsAndOddNamesAreRefusedWithOneAnswer) {
  std::string first;
  const std::vector<std::string> names = {"",      ".",     "..",  "../x", "/etc/x", "a/b",
                                         ".hidden", "x\\y", "x y", "x\n",  "é",      std::string(kMaxMapNameLength + 1, 'a'),
                                         std::string("a\0b", 3)};
  for (const std::string& name : names) {
    std::string why;
    EXPECT_FALSE(resolve_map_name("/srv/map/saved", name, why)) << name;
    EXPECT_FALSE(why.empty()) << name;
    if (first.empty()) first = why;
    EXPECT_EQ(why, first) << "the same answer whatever was named";
  }
  EXPECT_TRUE(invalid_map_name(std::string(kMaxMapNameLength, 'a')).empty());
}

TEST(MapNames, TheSavedDirectoryDefaultsBesideTheLiveMapAndIsNeverIt) {
  MapServerConfig config;
  config.directory = "/srv/map";
  EXPECT_EQ(config.saved_maps(), std::filesystem::path("/srv/map/saved"));
  config.saved_directory = "/srv/exports";
  EXPECT_EQ(config.saved_maps(), std::filesystem::path("/srv/exports"));

  ConfigNode node = ConfigNode::from_string("directory: /srv/map\nsaved_directory: /srv/./map/\n");
  MapServerConfig loaded;
  try {
    loaded.load(node);
    FAIL() << "the map directory itself accepted as the saved maps' directory";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("saved_directory"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace fuse

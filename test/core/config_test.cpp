// ConfigNode (fuse/core/config.hpp): typed reads, unknown-key refusal with the full key path,
// wrong types named by key, fixed-size vectors.
#include "fuse/core/config.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace {

using fuse::ConfigError;
using fuse::ConfigNode;

/// Runs fn, expects a ConfigError and returns its message.
template <typename Fn>
std::string config_error_of(Fn&& fn) {
  try {
    fn();
  } catch (const ConfigError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no ConfigError thrown";
  return "";
}

TEST(ConfigNode, ReadsValuesAndKeepsDefaultsForAbsentKeys) {
  ConfigNode root = ConfigNode::from_string("a: 3\nb: 2.5\nname: ivox\nflag: true\n");
  int a = 0;
  double b = 0.0, absent = 7.0;
  std::string name;
  bool flag = false;
  root.get("a", a).get("b", b).get("name", name).get("flag", flag).get("absent", absent);
  EXPECT_EQ(a, 3);
  EXPECT_DOUBLE_EQ(b, 2.5);
  EXPECT_EQ(name, "ivox");
  EXPECT_TRUE(flag);
  EXPECT_DOUBLE_EQ(absent, 7.0);
  EXPECT_NO_THROW(root.finish());
}

TEST(ConfigNode, UnknownKeyIsRefusedWithItsFullPath) {
  ConfigNode root = ConfigNode::from_string("update:\n  max_iter: 3\n  max_iterations: 4\nother: 1\n");
  int other = 0;
  root.get("other", other);
  ConfigNode update = root.child("update");
  int iterations = 0;
  update.get("max_iterations", iterations);
  EXPECT_EQ(iterations, 4);
  const std::string msg = config_error_of([&] { update.finish(); });
  EXPECT_NE(msg.find("update.max_iter"), std::string::npos) << msg;
  EXPECT_EQ(msg.find("max_iterations"), std::string::npos) << "a read key must not be reported: " << msg;
  EXPECT_NO_THROW(root.finish());  // 'update' was read via child()
}

TEST(ConfigNode, UnknownTopLevelKeyIsRefused) {
  ConfigNode root = ConfigNode::from_string("known: 1\ntypo_key: 2\n");
  int known = 0;
  root.get("known", known);
  const std::string msg = config_error_of([&] { root.finish(); });
  EXPECT_NE(msg.find("typo_key"), std::string::npos) << msg;
}

TEST(ConfigNode, WrongTypeIsRefusedNamingTheKey) {
  ConfigNode root = ConfigNode::from_string("imu:\n  rate: fast\n");
  ConfigNode imu = root.child("imu");
  double rate = 0.0;
  const std::string msg = config_error_of([&] { imu.get("rate", rate); });
  EXPECT_NE(msg.find("imu.rate"), std::string::npos) << msg;
  EXPECT_NE(msg.find("fast"), std::string::npos) << msg;
}

TEST(ConfigNode, VectorsOfFixedSize) {
  ConfigNode root = ConfigNode::from_string("t: [1, 2.5, -3]\nq: [0, 0, 0, 1]\nshort: [1, 2]\nbad: [1, x, 3]\n");
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Eigen::Vector4d q = Eigen::Vector4d::Zero();
  root.get("t", t).get("q", q);
  EXPECT_EQ(t, Eigen::Vector3d(1, 2.5, -3));
  EXPECT_EQ(q, Eigen::Vector4d(0, 0, 0, 1));
  Eigen::Vector3d v;
  const std::string short_msg = config_error_of([&] { root.get("short", v); });
  EXPECT_NE(short_msg.find("short"), std::string::npos) << short_msg;
  EXPECT_NE(short_msg.find("3"), std::string::npos) << short_msg;
  const std::string bad_msg = config_error_of([&] { root.get("bad", v); });
  EXPECT_NE(bad_msg.find("bad"), std::string::npos) << bad_msg;
  EXPECT_NE(bad_msg.find("element 1"), std::string::npos) << bad_msg;
}

TEST(ConfigNode, CheckNamesTheKeyPath) {
  ConfigNode root = ConfigNode::from_string("map:\n  mode: x\n");
  ConfigNode map = root.child("map");
  EXPECT_NO_THROW(map.check(true, "mode", "ok"));
  const std::string msg = config_error_of([&] { map.check(false, "mode", "must be mapping"); });
  EXPECT_EQ(msg, "map.mode: must be mapping");
}

TEST(ConfigNode, NonMapAndInvalidYamlAreRefused) {
  EXPECT_THROW(ConfigNode::from_string("- 1\n- 2\n"), ConfigError);
  EXPECT_THROW(ConfigNode::from_string("a: [1, 2\n"), ConfigError);
  ConfigNode root = ConfigNode::from_string("section: 5\n");
  const std::string msg = config_error_of([&] { root.child("section"); });
  EXPECT_NE(msg.find("section"), std::string::npos) << msg;
}

/// A config file with `text` in the test's temporary directory; removed by the destructor.
struct TempConfig {
  explicit TempConfig(const std::string& text)
      : path(std::filesystem::temp_directory_path() / ("fuse_config_test_" + std::to_string(::getpid()) + ".yaml")) {
    std::ofstream(path) << text;
  }
  ~TempConfig() { std::filesystem::remove(path); }
  std::filesystem::path path;
};

// An empty config file would run on every default without a word: refused naming the file, by
// the loader that fuse-run and the services share (and ConfigNode::from_file).
TEST(ConfigFile, EmptyOrNonMapFileIsRefusedNamingTheFile) {
  for (const std::string text : {"", "# only a comment\n", "- estimator\n- update\n", "just text\n"}) {
    TempConfig file(text);
    const std::string msg = config_error_of([&] { fuse::load_yaml_file(file.path.string(), {"estimator.a=1"}); });
    EXPECT_NE(msg.find(file.path.string()), std::string::npos) << "'" << text << "': " << msg;
    EXPECT_NE(config_error_of([&] { ConfigNode::from_file(file.path.string()); }).find(file.path.string()),
              std::string::npos);
  }
  TempConfig good("estimator:\n  gravity_magnitude: 9.8\n");
  EXPECT_TRUE(fuse::load_yaml_file(good.path.string()).IsMap());
}

}  // namespace

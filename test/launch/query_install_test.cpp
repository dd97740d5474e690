// The installed package: `cmake --install --component query` into a temporary prefix gives the
// library, the one standard-library-only header, the CMake package and fuse-query; a project
// outside FUSE configures with find_package(fuse-slam), links fuse-slam::query only, builds and runs
// (DDS domain 44, no server there).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <regex>

#include "test_helpers.hpp"

namespace fuse::query {
namespace {

namespace fs = std::filesystem;

class QueryInstall : public ::testing::Test {
 protected:
  /// Runs a shell command with its output in `log`; returns the exit code.
  int run(const std::string& command) {
    const int status = std::system((command + " >> " + log() + " 2>&1").c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  std::string log() const { return dir_.str("commands.log"); }
  std::string prefix() const { return dir_.str("prefix"); }
  std::string output() const { return test::read_text(log()); }

  /// The one directory under the prefix holding `name` (lib or lib/<multiarch>).
  fs::path find(const std::string& name) const {
    for (const auto& e : fs::recursive_directory_iterator(prefix())) {
      if (e.path().filename() == name) return e.path();
    }
    return {};
  }

  test::TempDir dir_{"fuse-query-install"};
};

TEST_F(QueryInstall, InstallsAPackageAnOutsideProjectBuildsAgainst) {
  const std::string cmake = "'" + std::string(FUSE_CMAKE_COMMAND) + "'";
  ASSERT_EQ(run(cmake + " --install '" + FUSE_BUILD_DIR + "' --prefix '" + prefix() + "' --component query"), 0)
      << output();

  // The header, and nothing but the standard library in it.
  const fs::path header = fs::path(prefix()) / "include/fuse-slam/fuse/query/client.hpp";
  ASSERT_TRUE(fs::exists(header)) << output();
  int headers = 0;
  for (const auto& e : fs::recursive_directory_iterator(fs::path(prefix()) / "include")) headers += e.is_regular_file();
  EXPECT_EQ(headers, 1) << "only client.hpp is installed";
  const std::string text = test::read_text(header.string());
  const std::regex include_line(R"(#\s*include\s*(\S+))");
  const std::regex standard(R"(<[a-z_]+>)");
  for (std::sregex_iterator it(text.begin(), text.end(), include_line), end; it != end; ++it) {
    EXPECT_TRUE(std::regex_match((*it)[1].str(), standard)) << "not a standard header: " << (*it)[1];
  }
  EXPECT_FALSE(find("libfuse_slam_query.so.3").empty());
  EXPECT_FALSE(find("fuse-slamConfig.cmake").empty());
  EXPECT_FALSE(find("fuse-slamConfigVersion.cmake").empty());
  EXPECT_TRUE(find("libfuse_transport.a").empty()) << "static libraries stay inside the .so";

  // An outside project: configure, build, run.
  const std::string build = dir_.str("consumer-build");
  ASSERT_EQ(run(cmake + " -S '" + FUSE_CONSUMER_SOURCE + "' -B '" + build + "' -DCMAKE_PREFIX_PATH='" + prefix() +
                "' -DCMAKE_CXX_COMPILER='" + FUSE_CXX_COMPILER + "' -DCMAKE_BUILD_TYPE=Release"),
            0)
      << output();
  ASSERT_EQ(run(cmake + " --build '" + build + "'"), 0) << output();
  ASSERT_EQ(run("'" + build + "/fuse_query_consumer' 44"), 0) << output();
  EXPECT_NE(output().find("consumer ok"), std::string::npos) << output();

  // The installed tool finds the installed library (RPATH $ORIGIN/../lib...).
  EXPECT_EQ(run("'" + prefix() + "/bin/fuse-query' --help"), 0) << output();
  EXPECT_EQ(run("'" + prefix() + "/bin/fuse-query' --set transport.domain_id=44 --deadline-ms 200"), 4) << output();
}

}  // namespace
}  // namespace fuse::query

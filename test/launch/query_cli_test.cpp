// fuse-query against a stand-in query server (DDS domain 42): --json parsed back, the text
// output, the config's transport section, and the exit codes (0 answered, 2 usage, 3 error
// reply, 4 unavailable: domain 43 has no server).
#include <gtest/gtest.h>
#include <json/json.h>
#include <sys/wait.h>

#include <cmath>

#include "query_server.hpp"
#include "test_helpers.hpp"

namespace fuse::query {
namespace {

namespace qt = test::query_times;
constexpr int kServerDomain = 42;
constexpr int kEmptyDomain = 43;

class QueryCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { server_ = new test::FakeQueryServer(kServerDomain); }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
  }

  struct Run {
    int code = -1;
    std::string out, err;
  };
  Run query(const std::string& args, int domain = kServerDomain) {
    const std::string cmd = std::string(FUSE_QUERY_BIN) + " --set transport.domain_id=" + std::to_string(domain) +
                            " " + args + " > " + dir_.str("out") + " 2> " + dir_.str("err");
    const int status = std::system(cmd.c_str());
    Run r;
    r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = test::read_text(dir_.str("out"));
    r.err = test::read_text(dir_.str("err"));
    return r;
  }
  static Json::Value parse(const std::string& text) {
    Json::Value v;
    Json::CharReaderBuilder builder;
    std::string errors;
    std::istringstream in(text);
    EXPECT_TRUE(Json::parseFromStream(builder, in, &v, &errors)) << errors << "\n" << text;
    EXPECT_TRUE(v.isObject()) << text;
    return v;
  }
  static std::vector<double> numbers(const Json::Value& array) {
    std::vector<double> out;
    for (const auto& x : array) out.push_back(x.asDouble());
    return out;
  }

  static test::FakeQueryServer* server_;
  test::TempDir dir_{"fuse-query-test"};
};
test::FakeQueryServer* QueryCli::server_ = nullptr;

TEST_F(QueryCli, JsonOutputParsesBackToTheKnownEstimate) {
  const Run r = query("--time 100 --json --deadline-ms 10000");
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << "one JSON object on one line";
  const Json::Value v = parse(r.out);
  const auto msg = test::known_estimate(qt::kInterpolated, fuse_msgs::STATUS_INTERPOLATED);
  EXPECT_EQ(v["error"].asString(), "ok");
  EXPECT_EQ(v["message"].asString(), "");
  EXPECT_EQ(v["status"].asString(), "interpolated");
  EXPECT_EQ(v["t"].asDouble(), 100.0);
  EXPECT_EQ(numbers(v["position"]), (std::vector<double>{101.0, -2.5, 0.125}));
  EXPECT_EQ(numbers(v["orientation_xyzw"]), (std::vector<double>{0.0, 0.0, std::sin(0.25), std::cos(0.25)}))
      << "numbers round-trip exactly";
  EXPECT_EQ(numbers(v["velocity"]), (std::vector<double>{0.5, -0.25, 0.1}));
  const auto& P = msg.pose_covariance();
  const auto& V = msg.velocity_covariance();
  EXPECT_EQ(numbers(v["pose_covariance_diagonal"]), (std::vector<double>{P[0], P[7], P[14], P[21], P[28], P[35]}));
  EXPECT_EQ(numbers(v["velocity_covariance_diagonal"]), (std::vector<double>{V[0], V[4], V[8]}));
  EXPECT_EQ(numbers(v["pose_covariance"]), std::vector<double>(P.begin(), P.end()));
  EXPECT_EQ(numbers(v["velocity_covariance"]), std::vector<double>(V.begin(), V.end()));
}

TEST_F(QueryCli, TextOutputOfTheLatestEstimate) {
  const Run r = query("--latest --deadline-ms 10000");
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("t: 105.5\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("status: propagated\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("position: 106.5 -2.5 0.125\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("velocity: 0.5 -0.25 0.1055\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("pose_covariance_diagonal: 0.0625 0.125 0.1875 0.25 0.3125 0.375\n"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("velocity_covariance_diagonal: 0.5 1 1.5\n"), std::string::npos) << r.out;
  EXPECT_EQ(query("--deadline-ms 10000").out, r.out) << "--latest is the default";
}

TEST_F(QueryCli, ReadsTheTransportSectionOfAConfigFile) {
  test::write_text(dir_.str("fuse.yaml"), "estimator:\n  history:\n    length_s: 5.0\ntransport:\n  vendor: fastdds\n"
                                          "  domain_id: " + std::to_string(kEmptyDomain) + "\n");
  // query() adds --set transport.domain_id=42, applied over the file: the server's domain.
  Run r = query("--config " + dir_.str("fuse.yaml") + " --time 150 --json --deadline-ms 10000");
  EXPECT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_EQ(parse(r.out)["status"].asString(), "interpolated");
  // Without the override the file's domain (no server there) is used.
  const std::string cmd = std::string(FUSE_QUERY_BIN) + " --config " + dir_.str("fuse.yaml") +
                          " --latest --deadline-ms 300 > /dev/null 2>&1";
  const int status = std::system(cmd.c_str());
  EXPECT_EQ(WEXITSTATUS(status), 4);
}

TEST_F(QueryCli, AnErrorReplyExitsWithThree) {
  Run r = query("--time 50 --json --deadline-ms 10000");
  EXPECT_EQ(r.code, 3) << r.out << r.err;
  Json::Value v = parse(r.out);
  EXPECT_EQ(v["error"].asString(), "not_ready");
  EXPECT_EQ(v["message"].asString(), "IMU does not cover t yet");
  EXPECT_FALSE(v.isMember("position"));
  r = query("--time 51 --deadline-ms 10000");
  EXPECT_EQ(r.code, 3);
  EXPECT_NE(r.err.find("internal"), std::string::npos) << r.err;
  EXPECT_TRUE(r.out.empty());
}

TEST_F(QueryCli, ATimeOutsideTheHistoryOrALostEstimatorIsNotOk) {
  Run r = query("--time " + std::to_string(qt::kTooOld) + " --json --deadline-ms 10000");
  EXPECT_EQ(r.code, 3) << r.out << r.err;
  Json::Value v = parse(r.out);
  EXPECT_EQ(v["error"].asString(), "out_of_range");
  EXPECT_EQ(v["status"].asString(), "too_old");  // the answer is there, with its status
  EXPECT_FALSE(v["message"].asString().empty());
  r = query("--time " + std::to_string(qt::kLost) + " --deadline-ms 10000");
  EXPECT_EQ(r.code, 3);
  EXPECT_NE(r.err.find("not_tracking"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("status: lost"), std::string::npos) << r.err;
}

TEST_F(QueryCli, AnInvalidTimeIsABadRequestNotSent) {
  for (const char* t : {"nan", "inf", "-1", "1e12"}) {
    const Run r = query(std::string("--json --time ") + t);
    EXPECT_EQ(r.code, 3) << t;
    EXPECT_EQ(parse(r.out)["error"].asString(), "bad_request") << t;
  }
  EXPECT_EQ(server_->invalid_requests(), 0);
}

TEST_F(QueryCli, NoServerExitsWithFourAfterTheDeadline) {
  const auto start = std::chrono::steady_clock::now();
  const Run r = query("--latest --json --deadline-ms 300", kEmptyDomain);
  EXPECT_EQ(r.code, 4) << r.out << r.err;
  EXPECT_GE(test::seconds_since(start), 0.3);
  EXPECT_EQ(parse(r.out)["error"].asString(), "unavailable");
}

TEST_F(QueryCli, UsageErrorsExitWithTwo) {
  EXPECT_EQ(query("--time abc").code, 2);
  EXPECT_EQ(query("--time").code, 2);
  EXPECT_EQ(query("--time 1 --latest").code, 2);
  EXPECT_EQ(query("--bogus").code, 2);
  EXPECT_EQ(query("--deadline-ms 0").code, 2);
  EXPECT_EQ(query("--deadline-ms 12x").code, 2);
  EXPECT_EQ(query("--config " + dir_.str("missing.yaml")).code, 2);
  EXPECT_EQ(query("--set transport.vendor=opendds").code, 2);
  EXPECT_EQ(query("--set transport.unknown_key=1").code, 2);
  EXPECT_EQ(query("--set novalue").code, 2);
  EXPECT_EQ(query("--set transport.domain_id=500").code, 2);
  const Run wildcard = query("--system 'rig*'");  // a partition wildcard would match other systems
  EXPECT_EQ(wildcard.code, 2);
  EXPECT_NE(wildcard.err.find("system_name"), std::string::npos) << wildcard.err;
  const Run help = query("--help");
  EXPECT_EQ(help.code, 0);
  EXPECT_NE(help.out.find("Usage: fuse-query"), std::string::npos);
  const Run bogus = query("--bogus");
  EXPECT_NE(bogus.err.find("--bogus"), std::string::npos) << bogus.err;
  const Run version = query("--version");
  EXPECT_EQ(version.code, 0);
  EXPECT_NE(version.out.find("fuse-query (FUSE-SLAM) "), std::string::npos) << version.out;
}

}  // namespace
}  // namespace fuse::query

// Accuracy guards on a simulated corridor (exact ground truth) and the ablations that show each
// mechanism earns its place: with deskew off or the degeneracy-aware update off the error is
// measurably worse. Loose bounds: they guard behaviour; the figures live in docs/evaluation.md.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "fuse/eval/evaluate.hpp"
#include "fuse/eval/trajectory.hpp"
#include "runner.hpp"

namespace fuse {
namespace {

const std::string kShort = std::string(FUSE_TEST_DATA) + "/corridor60";
const std::string kLoop = std::string(FUSE_TEST_DATA) + "/corridor_loop";
const std::string kConfig = std::string(FUSE_CONFIG_DIR) + "/mid360.yaml";

struct Outcome {
  RunSummary run;
  eval::EvaluationResult eval;
};

Outcome run_with(const std::string& data, const std::vector<std::string>& overrides) {
  Outcome o;
  o.run = run_offline(load_runner_config(kConfig, overrides), data + "/recording.mcap", "");
  if (o.run.error.empty()) {
    eval::EvaluationConfig ec;
    ec.rpe_delta_m = 5.0;
    o.eval = eval::evaluate(eval::read_tum(data + "/groundtruth.tum"), o.run.trajectory, ec);
  }
  return o;
}

class CorridorTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    ASSERT_TRUE(std::filesystem::exists(kShort + "/recording.mcap")) << "fixture missing: " << kShort;
    full_ = new Outcome(run_with(kShort, {}));
  }
  static void TearDownTestSuite() { delete full_; }
  static Outcome* full_;
};
Outcome* CorridorTest::full_ = nullptr;

TEST_F(CorridorTest, FullConfigurationTracksTheCorridor) {
  ASSERT_TRUE(full_->run.error.empty()) << full_->run.error;
  EXPECT_GT(full_->run.scans_updated, 500u);
  // ~70 m of walking: a working filter stays within a few centimetres; 0.15 m guards against regressions.
  EXPECT_LT(full_->eval.ate.rmse, 0.15);
  RecordProperty("ate_rmse_m", std::to_string(full_->eval.ate.rmse));
}

TEST_F(CorridorTest, WithoutDeskewTheErrorIsWorse) {
  const Outcome no_deskew = run_with(kShort, {"estimator.preprocess.deskew=false"});
  if (no_deskew.run.error.empty()) {
    EXPECT_GT(no_deskew.eval.ate.rmse, 1.5 * full_->eval.ate.rmse);
  } else {
    SUCCEED() << "without deskew the estimator failed: " << no_deskew.run.error;
  }
}

// The whole 418 m loop: its corners and long straights are where weak directions matter (on a
// one- or two-minute piece the two configurations are within noise of each other).
TEST(CorridorLoopTest, FullConfigurationClosesTheLoopAndBeatsNoDegeneracyAwareUpdate) {
  ASSERT_TRUE(std::filesystem::exists(kLoop + "/recording.mcap")) << "fixture missing: " << kLoop;
  const Outcome full = run_with(kLoop, {});
  ASSERT_TRUE(full.run.error.empty()) << full.run.error;
  // Target: end-to-end loop error at most 0.4 % of the loop length.
  EXPECT_LT(full.eval.end_to_end_m, 0.004 * full.eval.path_length_m);
  const Outcome no_degeneracy = run_with(kLoop, {"estimator.update.degeneracy.enabled=false"});
  ASSERT_TRUE(no_degeneracy.run.error.empty()) << no_degeneracy.run.error;
  EXPECT_GT(no_degeneracy.eval.ate.rmse, 1.1 * full.eval.ate.rmse)
      << "full " << full.eval.ate.rmse << " m, without degeneracy-aware update " << no_degeneracy.eval.ate.rmse << " m";
}

}  // namespace
}  // namespace fuse

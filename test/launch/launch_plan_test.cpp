// fuse-launch's plan: the services in start order with their command lines; --viz adds fuse-viz
// before the driver, with the shared config and overrides.
#include <gtest/gtest.h>

#include <algorithm>

#include "fuse/launch/launch_plan.hpp"

namespace fuse::launch {
namespace {

std::vector<std::string> names(const LaunchPlan& plan) {
  std::vector<std::string> out;
  for (const ServiceSpec& s : plan.services) out.push_back(s.name);
  return out;
}

TEST(LaunchPlan, VizIsAFifthServiceBeforeTheDriverOnlyWhenAsked) {
  LaunchOptions o;
  o.config_file = "system.yaml";
  o.input = "recording.mcap";
  o.bin_dir = "/opt/fuse/bin";
  o.domain_id = 42;
  EXPECT_EQ(names(make_launch_plan(o, 0.0)),
            (std::vector<std::string>{"fuse-map", "fuse-state", "fuse-update", "fuse-ingest"}));
  o.viz = true;
  o.restart = true;
  const LaunchPlan plan = make_launch_plan(o, 0.0);
  ASSERT_EQ(names(plan), (std::vector<std::string>{"fuse-map", "fuse-state", "fuse-update", "fuse-viz", "fuse-ingest"}));
  const ServiceSpec& viz = plan.services[3];
  EXPECT_EQ(viz.argv.front(), "/opt/fuse/bin/fuse-viz");
  EXPECT_NE(std::find(viz.argv.begin(), viz.argv.end(), "system.yaml"), viz.argv.end());
  EXPECT_NE(std::find(viz.argv.begin(), viz.argv.end(), "transport.domain_id=42"), viz.argv.end());
  EXPECT_TRUE(viz.restart);
  EXPECT_FALSE(viz.exit_zero_is_done);
}

}  // namespace
}  // namespace fuse::launch

// TrackingMonitor (tracking_monitor.hpp): tracking / relocalizing / lost from scan reports and the
// tracker's events, with reasons and episodes; a lost track returns to tracking on a good fit.
#include "fuse/estimation/tracking_monitor.hpp"

#include <gtest/gtest.h>

#include "../core/config_checks.hpp"
#include "fuse/estimation/estimator_config.hpp"

namespace fuse {
namespace {

constexpr double kScanDt = 0.1;
constexpr double kT0 = 1000.0;

TrackingConfig config() {
  TrackingConfig c;
  c.min_fit = 0.6;
  c.min_constraints = 50;
  c.max_failed_relocalisations = 5;
  c.max_poor_fits = 5;
  c.max_time_without_update_s = 1.0;
  c.max_position_std = 5.0;
  return c;
}

ScanReport good(double t) {
  ScanReport r;
  r.t = t;
  r.updated = true;
  r.converged = true;
  r.fit = 0.8;
  r.match_fit = 0.9;
  r.constraints = 1000;
  r.prior_position_std = 0.01;
  return r;
}

ScanReport relocalised(double t, double fit, bool converged = true) {
  ScanReport r = good(t);
  r.recovery = true;
  r.match_fit = fit;
  r.converged = converged;
  r.prior_position_std = 0.5;
  return r;
}

TEST(TrackingMonitor, GoodScansAreTracking) {
  TrackingMonitor m(config());
  for (int k = 0; k < 20; ++k) m.on_scan(good(kT0 + k * kScanDt));
  EXPECT_EQ(m.status(), TrackingStatus::kTracking);
  EXPECT_TRUE(m.reason().empty());
  EXPECT_TRUE(m.episodes().empty());
}

TEST(TrackingMonitor, GapThenReLocalisationIsARelocalizingEpisode) {
  TrackingMonitor m(config());
  double t = kT0;
  for (int k = 0; k < 10; ++k, t += kScanDt) m.on_scan(good(t));
  m.on_event(TrackingEvent::kDataGap, t);
  EXPECT_EQ(m.status(), TrackingStatus::kRelocalizing);
  EXPECT_NE(m.reason().find("data gap"), std::string::npos) << m.reason();
  m.on_scan(relocalised(t, 0.3));  // not yet a good fit
  t += kScanDt;
  m.on_scan(relocalised(t, 0.4, false));
  t += kScanDt;
  EXPECT_EQ(m.status(), TrackingStatus::kRelocalizing);
  m.on_scan(relocalised(t, 0.7));  // re-localised: the next, confident scan decides
  t += kScanDt;
  EXPECT_EQ(m.status(), TrackingStatus::kRelocalizing);
  EXPECT_NE(m.reason().find("re-localised"), std::string::npos) << m.reason();
  m.on_scan(good(t));
  EXPECT_EQ(m.status(), TrackingStatus::kTracking);
  ASSERT_EQ(m.episodes().size(), 1u);
  EXPECT_EQ(m.episodes()[0].status, TrackingStatus::kRelocalizing);
  EXPECT_NEAR(m.episodes()[0].duration, 3 * kScanDt, 1e-9);
  EXPECT_NEAR(m.time_in(TrackingStatus::kRelocalizing), 3 * kScanDt, 1e-9);
  EXPECT_EQ(m.time_in(TrackingStatus::kLost), 0.0);
}

TEST(TrackingMonitor, ReLocalisationThatKeepsFailingIsLostThenRecovers) {
  TrackingMonitor m(config());
  double t = kT0;
  m.on_scan(good(t));
  for (int k = 0; k < 6; ++k) m.on_scan(relocalised(t += kScanDt, 0.2));
  EXPECT_EQ(m.status(), TrackingStatus::kLost);
  EXPECT_NE(m.reason().find("re-localisation failed 6 scans"), std::string::npos) << m.reason();
  m.on_event(TrackingEvent::kDataGap, t);  // lost stays lost until a scan fits
  EXPECT_EQ(m.status(), TrackingStatus::kLost);
  EXPECT_TRUE(m.wants_relocalisation());
  m.on_scan(relocalised(t += kScanDt, 0.2));
  EXPECT_TRUE(m.wants_relocalisation());
  m.on_scan(relocalised(t += kScanDt, 0.9));  // re-localised: still lost until a confident scan fits
  EXPECT_EQ(m.status(), TrackingStatus::kLost);
  EXPECT_FALSE(m.wants_relocalisation());
  m.on_scan(good(t += kScanDt));
  EXPECT_EQ(m.status(), TrackingStatus::kTracking);
  ASSERT_EQ(m.episodes().size(), 2u);
  EXPECT_EQ(m.episodes()[1].status, TrackingStatus::kLost);
  EXPECT_NEAR(m.longest(TrackingStatus::kLost), 3 * kScanDt, 1e-9);
}

TEST(TrackingMonitor, NoUpdateWhileScansArriveIsLost) {
  TrackingMonitor m(config());
  double t = kT0;
  m.on_scan(good(t));
  ScanReport starved;  // no constraints: not updated
  for (int k = 0; k < 12; ++k) {
    starved.t = (t += kScanDt);
    m.on_scan(starved);
  }
  EXPECT_EQ(m.status(), TrackingStatus::kLost);
  EXPECT_NE(m.reason().find("no scan has fit the map"), std::string::npos) << m.reason();
}

// A stretch in which no scan arrived (scans published while a restarted fuse-update was down)
// is not time spent failing to fit: a poor scan after it is one poor scan, not 7 s of them.
TEST(TrackingMonitor, AStretchWithoutScansIsNotTimeWithoutAFit) {
  TrackingMonitor m(config());
  double t = kT0;
  m.on_scan(good(t));
  m.on_scan(good(t += kScanDt));
  ScanReport starved;  // no constraints: not updated
  starved.t = (t += 7.0);
  m.on_scan(starved);
  EXPECT_NE(m.status(), TrackingStatus::kLost) << m.reason();
  for (int k = 0; k < 12; ++k) {  // scans that do arrive and do not fit still make it lost
    starved.t = (t += kScanDt);
    m.on_scan(starved);
  }
  EXPECT_EQ(m.status(), TrackingStatus::kLost);
}

TEST(TrackingMonitor, RefusedScansCountAsTimeWithoutUpdate) {
  TrackingMonitor m(config());
  m.on_scan(good(kT0));
  m.on_scan(good(kT0 + kScanDt));  // the scan period: 0.1 s
  for (int k = 0; k < 9; ++k) m.on_refused_scan();
  EXPECT_EQ(m.status(), TrackingStatus::kTracking);  // 0.9 s: not yet more than 1 s
  m.on_refused_scan();
  m.on_refused_scan();
  EXPECT_EQ(m.status(), TrackingStatus::kLost);
  EXPECT_NE(m.reason().find("refused"), std::string::npos) << m.reason();
}

TEST(TrackingMonitor, ConfidentPriorThatKeepsFittingPoorlyIsLost) {
  TrackingMonitor m(config());
  double t = kT0;
  m.on_scan(good(t));
  ScanReport poor = good(t);
  poor.match_fit = 0.4;
  for (int k = 0; k < 6; ++k) {
    poor.t = (t += kScanDt);
    m.on_scan(poor);
  }
  EXPECT_EQ(m.status(), TrackingStatus::kLost);
  EXPECT_NE(m.reason().find("without a good fit"), std::string::npos) << m.reason();
  // Not re-localised from scratch (that lost usable estimates): its scans keep being updated,
  // and the first that fits well again is tracking.
  EXPECT_FALSE(m.wants_relocalisation());
  poor.t = (t += kScanDt);
  m.on_scan(poor);
  EXPECT_EQ(m.status(), TrackingStatus::kLost);
  m.on_scan(good(t += kScanDt));
  EXPECT_EQ(m.status(), TrackingStatus::kTracking);
}

TEST(TrackingMonitor, ConstraintStarvationIsLost) {
  TrackingMonitor m(config());
  double t = kT0;
  m.on_scan(good(t));
  ScanReport starved = good(t);
  starved.constraints = 20;  // fits, but hardly anything to fit
  for (int k = 0; k < 6; ++k) {
    starved.t = (t += kScanDt);
    m.on_scan(starved);
  }
  EXPECT_EQ(m.status(), TrackingStatus::kLost);
  EXPECT_NE(m.reason().find("20 constraints"), std::string::npos) << m.reason();
}

TEST(TrackingMonitor, LostWithoutUpdatesAsksForReLocalisationUntilOneSucceeds) {
  TrackingMonitor m(config());
  double t = kT0;
  m.on_scan(good(t));
  m.on_scan(good(t += kScanDt));
  for (int k = 0; k < 12; ++k) m.on_refused_scan();
  ASSERT_EQ(m.status(), TrackingStatus::kLost);
  EXPECT_TRUE(m.wants_relocalisation());
  m.on_scan(relocalised(t += 1.3, 0.3));  // failed: try again
  EXPECT_TRUE(m.wants_relocalisation());
  m.on_scan(relocalised(t += kScanDt, 0.8));  // re-localised: the next scan runs from it
  EXPECT_FALSE(m.wants_relocalisation());
  EXPECT_EQ(m.status(), TrackingStatus::kLost);
  m.on_scan(good(t += kScanDt));
  EXPECT_EQ(m.status(), TrackingStatus::kTracking);
  EXPECT_FALSE(m.wants_relocalisation());
}

TEST(TrackingMonitor, PriorBeyondLocalReLocalisationIsLostUnlessTheScanFits) {
  TrackingMonitor m(config());
  ScanReport wide = relocalised(kT0, 0.1);
  wide.prior_position_std = 20.0;
  m.on_scan(wide);
  EXPECT_EQ(m.status(), TrackingStatus::kLost);
  EXPECT_NE(m.reason().find("beyond local re-localisation"), std::string::npos) << m.reason();
  wide.t += kScanDt;
  wide.match_fit = 0.9;
  m.on_scan(wide);
  m.on_scan(good(wide.t + kScanDt));
  EXPECT_EQ(m.status(), TrackingStatus::kTracking);
}

TEST(TrackingMonitor, NoDurationAcrossAClockStep) {
  TrackingMonitor m(config());
  m.on_scan(good(kT0));
  m.on_event(TrackingEvent::kClockStep, kT0 + 100.0);
  m.on_scan(relocalised(kT0 + 100.05, 0.3));  // 100 s later by the stamps, 0.1 s in fact
  m.on_scan(relocalised(kT0 + 100.15, 0.8));
  m.on_scan(good(kT0 + 100.25));
  EXPECT_EQ(m.status(), TrackingStatus::kTracking);
  EXPECT_NEAR(m.time_in(TrackingStatus::kRelocalizing), 0.2, 1e-9);
}

TEST(TrackingConfig, BadValuesAreRefusedNamingTheKey) {
  expect_refused_naming_the_key<TrackingConfig>({"min_fit: 2", "min_constraints: -1", "max_failed_relocalisations: 0",
                                                 "max_poor_fits: 0", "max_time_without_update_s: 0",
                                                 "max_position_std: -1", "max_lost_s: -1", "typo: 1"});
}

TEST(TimeOffsetConfig, BadValuesAreRefusedNamingTheKey) {
  expect_refused_naming_the_key<TimeOffsetConfig>({"max_s: 0", "initial_s: 0.5", "std_s: 0", "random_walk: -1",
                                                   "hold_after_relocalisation_s: -1", "rate_smoothing_s: -0.01",
                                                   "rate_smoothing_s: 2", "typo: 1"});
}

}  // namespace
}  // namespace fuse

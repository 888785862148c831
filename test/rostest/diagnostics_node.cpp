// The node's /diagnostics report (no roscore needed; run by diagnostics.test with the other
// ROS-layer tests): levels, messages and values for each condition.

#include <gtest/gtest.h>

#include <string>

#include "rbpf_slam/ros/diagnostics.h"

namespace rbpf_slam {
namespace {

std::string value(const diagnostic_msgs::DiagnosticStatus& status, const std::string& key) {
  for (const auto& kv : status.values) {
    if (kv.key == key) return kv.value;
  }
  return "<missing " + key + ">";
}

core::FilterStats healthy() {
  core::FilterStats stats;
  stats.last_neff = 80.0;
  stats.landmarks = 12;
  return stats;
}

TEST(Diagnostics, OkWhileMappingWithTheFigures) {
  rosbridge::SlamDiagnostics diagnostics("rbpf_slam_node");
  diagnostics.recordUpdate(2.0);
  diagnostics.recordUpdate(4.0);
  const auto array = diagnostics.report(ros::Time(10.0), healthy(), 100, 1.0);
  ASSERT_EQ(array.status.size(), 1u);
  const auto& s = array.status[0];
  EXPECT_EQ(s.level, diagnostic_msgs::DiagnosticStatus::OK);
  EXPECT_EQ(s.message, "mapping");
  EXPECT_EQ(value(s, "updates"), "2");
  EXPECT_EQ(value(s, "update time mean [ms]"), "3");
  EXPECT_EQ(value(s, "landmarks"), "12");
  EXPECT_EQ(value(s, "Neff"), "80");
}

/// Input handled most of the wall time: the node falls behind, and roscpp drops the frames its
/// topic queue cannot hold without a word, so the report says so (above 90 %, in whole percent),
/// before the drops and the low Neff that follow from it.
TEST(Diagnostics, BusyMostOfTheTimeWarnsThatFramesAreDropped) {
  rosbridge::SlamDiagnostics diagnostics("rbpf_slam_node");
  diagnostics.recordUpdate(400.0);  // an update's time is not busy time by itself
  diagnostics.recordBusy(455.0);    // the callbacks' is (the update inside them)
  diagnostics.recordDrop("no tf in time");
  core::FilterStats degenerate = healthy();
  degenerate.last_neff = 3.0;
  auto s = diagnostics.report(ros::Time(1.0), degenerate, 100, 0.5).status[0];
  EXPECT_EQ(s.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_EQ(s.message,
            "handling input 91 % of the time: falling behind, the topic's queue drops frames "
            "unseen when full");
  EXPECT_EQ(value(s, "busy [%]"), "91");
  EXPECT_DOUBLE_EQ(diagnostics.lastBusyFraction(), 0.91);
  // 90 % (89.6 rounded) is not over 90 %: OK.
  diagnostics.recordUpdate(10.0);
  diagnostics.recordBusy(896.0);
  s = diagnostics.report(ros::Time(2.0), healthy(), 100, 1.0).status[0];
  EXPECT_EQ(s.level, diagnostic_msgs::DiagnosticStatus::OK) << s.message;
  EXPECT_EQ(value(s, "busy [%]"), "90");
  // Without a period (a timer catching up) no share; the busy time is carried into the next.
  diagnostics.recordBusy(300.0);
  s = diagnostics.report(ros::Time(3.0), healthy(), 100, 0.0).status[0];
  EXPECT_EQ(value(s, "busy [%]"), "<missing busy [%]>");
  EXPECT_EQ(s.level, diagnostic_msgs::DiagnosticStatus::OK);
  diagnostics.recordBusy(300.0);
  s = diagnostics.report(ros::Time(4.0), healthy(), 100, 1.0).status[0];
  EXPECT_EQ(value(s, "busy [%]"), "60");
}

/// The clock-reading report: a period shorter than kMinBusyPeriodS gives no share (the first
/// report here comes microseconds after construction), and its busy time is carried over.
TEST(Diagnostics, AShortPeriodGivesNoBusyShare) {
  rosbridge::SlamDiagnostics diagnostics("rbpf_slam_node");
  diagnostics.recordBusy(1e9);  // 1e6 s: far over any period the test can take
  auto s = diagnostics.report(ros::Time(1.0), healthy(), 100).status[0];
  if (value(s, "busy [%]") == "<missing busy [%]>") {  // the usual case: microseconds passed
    EXPECT_EQ(s.level, diagnostic_msgs::DiagnosticStatus::OK);
    EXPECT_DOUBLE_EQ(diagnostics.lastBusyFraction(), 0.0);
    // The carried time makes the next share over 100 %, whenever it comes.
    EXPECT_EQ(diagnostics.report(ros::Time(2.0), healthy(), 100, 1.0).status[0].level,
              diagnostic_msgs::DiagnosticStatus::WARN);
  } else {  // the machine stalled for over kMinBusyPeriodS: the share is given, and huge
    EXPECT_EQ(s.level, diagnostic_msgs::DiagnosticStatus::WARN);
  }
}

/// Nested BusyScopes (a callback whose tf gate hands its message on at once) record once, when
/// the outermost ends: nothing is recorded while it is open.
TEST(Diagnostics, NestedBusyScopesRecordOnlyTheOutermost) {
  rosbridge::SlamDiagnostics diagnostics("rbpf_slam_node");
  {
    const rosbridge::SlamDiagnostics::BusyScope outer(&diagnostics);
    { const rosbridge::SlamDiagnostics::BusyScope inner(&diagnostics); }
    // A report with a period of 1 ns would show any recorded time as an enormous share.
    diagnostics.report(ros::Time(1.0), healthy(), 100, 1e-9);
    EXPECT_DOUBLE_EQ(diagnostics.lastBusyFraction(), 0.0);
  }
  diagnostics.report(ros::Time(2.0), healthy(), 100, 1e-9);
  EXPECT_GT(diagnostics.lastBusyFraction(), 0.0);  // the outer scope's time
}

TEST(Diagnostics, EnsembleLeaderChangesAreShownOnceThereAreAny) {
  rosbridge::SlamDiagnostics diagnostics("rbpf_slam_node");
  diagnostics.recordUpdate(1.0);
  core::FilterStats stats = healthy();
  EXPECT_EQ(value(diagnostics.report(ros::Time(1.0), stats, 100, 1.0).status[0],
                  "ensemble leader changes"),
            "<missing ensemble leader changes>");
  stats.leader_changes = 3;
  EXPECT_EQ(value(diagnostics.report(ros::Time(2.0), stats, 100, 1.0).status[0],
                  "ensemble leader changes"),
            "3");
}

TEST(Diagnostics, DropsWarnForOnePeriodAndAreCountedByCause) {
  rosbridge::SlamDiagnostics diagnostics("rbpf_slam_node");
  diagnostics.recordUpdate(1.0);
  diagnostics.recordDrop("no tf");
  diagnostics.recordDrop("no tf");
  diagnostics.recordDrop("bad scan");
  auto s = diagnostics.report(ros::Time(1.0), healthy(), 100, 1.0).status[0];
  EXPECT_EQ(s.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_NE(s.message.find("3 message(s) dropped"), std::string::npos) << s.message;
  EXPECT_EQ(value(s, "dropped: no tf"), "2");
  EXPECT_EQ(value(s, "dropped: bad scan"), "1");
  diagnostics.recordUpdate(1.0);
  s = diagnostics.report(ros::Time(2.0), healthy(), 100, 1.0).status[0];
  EXPECT_EQ(s.level, diagnostic_msgs::DiagnosticStatus::OK) << "drops of an earlier period";
  EXPECT_EQ(value(s, "dropped: no tf"), "2") << "totals are kept";
}

TEST(Diagnostics, LowNeffSlowUpdatesAndPauseWarn) {
  rosbridge::SlamDiagnostics diagnostics("rbpf_slam_node");
  diagnostics.recordUpdate(1.0);
  core::FilterStats degenerate = healthy();
  degenerate.last_neff = 3.0;
  auto s = diagnostics.report(ros::Time(1.0), degenerate, 100, 1.0).status[0];
  EXPECT_EQ(s.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_NE(s.message.find("effective sample size"), std::string::npos) << s.message;

  diagnostics.recordUpdate(500.0);
  s = diagnostics.report(ros::Time(2.0), healthy(), 100, 1.0).status[0];
  EXPECT_EQ(s.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_NE(s.message.find("500 ms"), std::string::npos) << s.message;

  diagnostics.setPaused(true);
  s = diagnostics.report(ros::Time(3.0), healthy(), 100, 1.0).status[0];
  EXPECT_EQ(s.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_EQ(value(s, "paused"), "true");
}

TEST(Diagnostics, WaitingBeforeTheFirstUpdate) {
  rosbridge::SlamDiagnostics diagnostics("rbpf_slam_node");
  const auto s = diagnostics.report(ros::Time(1.0), core::FilterStats(), 100, 1.0).status[0];
  EXPECT_EQ(s.level, diagnostic_msgs::DiagnosticStatus::OK);
  EXPECT_EQ(s.message, "waiting for data");
}

// The OK message says what the node does: localizing on a loaded map, tracking, extracting
// features (each used to say "mapping"); nodes without ~pause report no "paused" value.
TEST(Diagnostics, TheOkMessageSaysWhatTheNodeDoes) {
  rosbridge::SlamDiagnostics slam("rbpf_slam_node");
  slam.recordUpdate(1.0);
  slam.setActivity("localizing (mapping off)");
  auto s = slam.report(ros::Time(1.0), healthy(), 100, 1.0).status[0];
  EXPECT_EQ(s.message, "localizing (mapping off)");
  EXPECT_EQ(value(s, "paused"), "false");
  rosbridge::SlamDiagnostics tracker("landmark_tracker",
                                     rosbridge::DiagnosticsOptions::withoutFilter("tracking"));
  tracker.recordUpdate(1.0);
  tracker.recordExpectedDrop("stamped before tf's first transform");  // start-up: no WARN
  s = tracker.report(ros::Time(1.0), core::FilterStats(), 0, 1.0).status[0];
  EXPECT_EQ(s.message, "tracking");
  EXPECT_EQ(s.level, diagnostic_msgs::DiagnosticStatus::OK);
  EXPECT_EQ(value(s, "dropped: stamped before tf's first transform"), "1");
  EXPECT_EQ(value(s, "paused"), "<missing paused>");
}

}  // namespace
}  // namespace rbpf_slam

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::Time::init();
  return RUN_ALL_TESTS();
}

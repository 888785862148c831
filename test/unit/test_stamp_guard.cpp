// core::StampGuard: a far-off /tf stamp must not stop tf for good (CheckedTransformListener).

#include <gtest/gtest.h>

#include "rbpf_slam/core/stamp_guard.h"

namespace rbpf_slam {
namespace core {
namespace {

constexpr double kDay = 86400.0;
constexpr double kNow = 1.7e9;  // the clock

TEST(StampGuard, AStampADayAheadOfTheStreamAndTheClockIsRefused) {
  StampGuard guard(kDay);
  EXPECT_EQ(guard.check("base", kNow, kNow), StampGuard::Verdict::kTake);
  guard.taken("base", kNow);
  EXPECT_EQ(guard.check("base", kNow + 2 * kDay, kNow + 1), StampGuard::Verdict::kRefuseAhead);
  EXPECT_EQ(guard.check("base", kNow + 2, kNow + 2), StampGuard::Verdict::kTake);
  // Both the transforms and the clock jump ahead (a clock set by network time): taken.
  EXPECT_EQ(guard.check("base", kNow + 3 * kDay, kNow + 3 * kDay), StampGuard::Verdict::kTake);
}

// A transform with its pair's newest stamp again (a converted log with coarse stamps; the shared
// Intel bag repeats 3346) is a repeat, which tf2 would refuse with a warning each: the listener
// skips it, whether or not the clock is known. Another pair at that stamp, or the pair at an
// older or newer one, is not a repeat.
TEST(StampGuard, ThePairsNewestStampAgainIsARepeat) {
  StampGuard guard(kDay);
  ASSERT_EQ(guard.check("base", kNow, kNow), StampGuard::Verdict::kTake);
  guard.taken("base", kNow);
  EXPECT_EQ(guard.check("base", kNow, kNow + 1), StampGuard::Verdict::kRepeat);
  EXPECT_EQ(guard.check("base", kNow, 0.0), StampGuard::Verdict::kRepeat) << "clock unknown";
  EXPECT_EQ(guard.check("laser", kNow, kNow + 1), StampGuard::Verdict::kTake);
  EXPECT_EQ(guard.check("base", kNow - 0.5, kNow + 1), StampGuard::Verdict::kTake);
  EXPECT_EQ(guard.check("base", kNow + 0.5, kNow + 1), StampGuard::Verdict::kTake);
  guard.clear();  // tf cleared: nothing taken, nothing repeats
  EXPECT_EQ(guard.check("base", kNow, kNow + 1), StampGuard::Verdict::kTake);
}

// The first transform has nothing to be compared with. Before, one stamped two days ahead was
// taken, and tf2 then refused every real transform of that pair as older: nothing moved again.
TEST(StampGuard, AFirstTransformFarAheadIsUndoneByTheFirstOneThatAgreesWithTheClock) {
  StampGuard guard(kDay);
  ASSERT_EQ(guard.check("base", kNow + 2 * kDay, kNow), StampGuard::Verdict::kTake);
  guard.taken("base", kNow + 2 * kDay);
  EXPECT_EQ(guard.check("base", kNow + 0.1, kNow + 0.1), StampGuard::Verdict::kRestart);
  guard.clear();  // the owner clears tf and takes it
  EXPECT_EQ(guard.check("base", kNow + 0.1, kNow + 0.1), StampGuard::Verdict::kTake);
  guard.taken("base", kNow + 0.1);
  // From now on the clock is known to be right: a far stamp is refused, even as the first
  // transform after a clear (a bag played again).
  EXPECT_EQ(guard.check("base", kNow + 2 * kDay, kNow + 0.2), StampGuard::Verdict::kRefuseAhead);
  guard.clear();
  EXPECT_EQ(guard.check("base", kNow + 2 * kDay, kNow + 0.3), StampGuard::Verdict::kRefuseAhead);
  EXPECT_EQ(guard.check("base", kNow + 0.3, kNow + 0.3), StampGuard::Verdict::kTake);
}

// A clock that agrees with no transform (a robot computer without network time, a bag played
// without its clock): the newest transform is the only reference, nothing restarts, as before.
TEST(StampGuard, AClockThatAgreesWithNoTransformRestartsNothing) {
  StampGuard guard(kDay);
  const double robot = 1.26e9;  // the transforms' clock, years behind this machine's
  guard.taken("base", robot);
  EXPECT_EQ(guard.check("base", robot + 1, kNow), StampGuard::Verdict::kTake);
  // A far-ahead glitch is still refused: after both the newest and the clock.
  EXPECT_EQ(guard.check("base", kNow + 2 * kDay, kNow), StampGuard::Verdict::kRefuseAhead);
  // A first transform stamped in the clock's time, then the robot's: no restart (the newest is
  // not ahead of the clock), tf2 decides per pair as before.
  StampGuard fresh(kDay);
  fresh.taken("base", kNow);
  EXPECT_EQ(fresh.check("base", robot, kNow), StampGuard::Verdict::kTake);
  // Unknown clock (0): no restart either.
  StampGuard unknown(kDay);
  unknown.taken("base", kNow + 2 * kDay);
  EXPECT_EQ(unknown.check("base", kNow, 0.0), StampGuard::Verdict::kTake);
}

// Pairs are told apart by child frame, as tf2 does: a robot whose clock is far ahead of this
// machine keeps its own pair; the node's own map -> odom, stamped by this clock, restarts
// nothing.
TEST(StampGuard, AnotherPairThatAgreesWithTheClockRestartsNothing) {
  StampGuard guard(kDay);
  const double robot = kNow + 3 * kDay;
  guard.taken("base_link", robot);
  EXPECT_EQ(guard.check("odom", kNow, kNow), StampGuard::Verdict::kTake);
  guard.taken("odom", kNow);
  EXPECT_EQ(guard.check("base_link", robot + 0.1, kNow + 0.1), StampGuard::Verdict::kTake);
}

// Once the clock is the reference, a glitch is refused against it alone: the newest taken
// cannot creep ahead a day at a time.
TEST(StampGuard, ATrustedClockIsTheOnlyReference) {
  StampGuard guard(kDay);
  guard.taken("base", kNow + 2 * kDay);
  ASSERT_EQ(guard.check("base", kNow, kNow), StampGuard::Verdict::kRestart);
  guard.clear();
  guard.taken("base", kNow);
  EXPECT_EQ(guard.check("base", kNow + 1.5 * kDay, kNow + 1), StampGuard::Verdict::kRefuseAhead);
  EXPECT_EQ(guard.check("base", kNow + 0.5 * kDay, kNow + 1), StampGuard::Verdict::kTake);
}

// A stale transform (more than a day behind) while the newest taken agrees with the clock is
// tf2's to refuse as old data: no restart.
TEST(StampGuard, AStaleTransformDoesNotRestart) {
  StampGuard guard(kDay);
  guard.taken("base", kNow);
  EXPECT_EQ(guard.check("base", kNow - 3 * kDay, kNow), StampGuard::Verdict::kTake);
}

}  // namespace
}  // namespace core
}  // namespace rbpf_slam

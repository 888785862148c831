// core::InOrderRelease: messages that leave a tf gate out of order are handed on in stamp order.

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "rbpf_slam/core/in_order_release.h"

using rbpf_slam::core::InOrderRelease;
using Names = std::vector<std::string>;

TEST(InOrderRelease, ALaterMessageWaitsForAnEarlierOneStillInTheGate) {
  InOrderRelease<double, std::string> order(10);
  order.entered(1.0, "a");
  order.entered(2.0, "b");
  order.entered(3.0, "c");
  EXPECT_EQ(order.left(2.0, "b"), Names{});  // 1.0 still waits for tf
  EXPECT_EQ(order.held(), 1u);
  EXPECT_EQ(order.left(1.0, "a"), (Names{"a", "b"}));
  EXPECT_EQ(order.left(3.0, "c"), Names{"c"});
  EXPECT_EQ(order.inGate(), 0u);
  EXPECT_EQ(order.held(), 0u);
}

TEST(InOrderRelease, ADroppedEarlierMessageLetsTheLaterOnesGo) {
  InOrderRelease<double, std::string> order(10);
  order.entered(1.0, "a");
  order.entered(2.0, "b");
  order.entered(3.0, "c");
  EXPECT_EQ(order.left(3.0, "c"), Names{});
  EXPECT_EQ(order.left(2.0, "b"), Names{});
  EXPECT_EQ(order.dropped(1.0, "a"), (Names{"b", "c"}));  // tf never came for 1.0
}

TEST(InOrderRelease, MessagesInOrderPassAtOnceAndEqualStampsDoNotBlockEachOther) {
  InOrderRelease<double, std::string> order(10);
  order.entered(1.0, "a");
  EXPECT_EQ(order.left(1.0, "a"), Names{"a"});
  order.entered(2.0, "b");
  order.entered(2.0, "b2");
  EXPECT_EQ(order.left(2.0, "b"), Names{"b"});
  EXPECT_EQ(order.left(2.0, "b2"), Names{"b2"});
  // A message that never entered (the gate answered for something unknown) passes too.
  EXPECT_EQ(order.left(5.0, "e"), Names{"e"});
}

TEST(InOrderRelease, AtMostMaxHeldWaitThenTheUnansweredEarlierStampIsForgotten) {
  InOrderRelease<double, std::string> order(2);
  order.entered(1.0, "a");
  order.entered(2.0, "b");
  order.entered(3.0, "c");
  order.entered(4.0, "d");
  EXPECT_EQ(order.left(2.0, "b"), Names{});
  EXPECT_EQ(order.left(3.0, "c"), Names{});
  EXPECT_EQ(order.left(4.0, "d"), (Names{"b", "c", "d"}));  // 1.0 given up on
  EXPECT_EQ(order.inGate(), 0u);
  // Should 1.0 still leave, it is handed on (late; the pipeline then refuses it, as before).
  EXPECT_EQ(order.left(1.0, "a"), Names{"a"});
}

/// A late answer for a message given up on does not take the entry of another message with
/// the same stamp (after a reset or a clock jump stamps repeat).
TEST(InOrderRelease, AnAnswerTakesOnlyItsOwnMessagesEntry) {
  InOrderRelease<double, std::string> order(1);
  order.entered(1.0, "a");
  order.entered(2.0, "b");
  order.entered(3.0, "c");
  EXPECT_EQ(order.left(2.0, "b"), Names{});
  EXPECT_EQ(order.left(3.0, "c"), (Names{"b", "c"}));  // "a" given up on (max_held 1)
  order.entered(1.0, "x");
  order.entered(1.5, "y");
  EXPECT_EQ(order.dropped(1.0, "a"), Names{});  // late: "x" (also 1.0) stays in the gate
  EXPECT_EQ(order.inGate(), 2u);
  EXPECT_EQ(order.left(1.5, "y"), Names{});  // "y" waits for "x"
  EXPECT_EQ(order.left(1.0, "x"), (Names{"x", "y"}));
}

TEST(InOrderRelease, ClearForgetsWhatWaitsAndWhatIsInTheGate) {
  InOrderRelease<double, std::string> order(10);
  order.entered(1.0, "a");
  order.entered(2.0, "b");
  EXPECT_EQ(order.left(2.0, "b"), Names{});
  order.clear();
  EXPECT_EQ(order.held(), 0u);
  EXPECT_EQ(order.inGate(), 0u);
  order.entered(7.0, "g");
  EXPECT_EQ(order.left(7.0, "g"), Names{"g"});
}

/// A message that can no longer leave the gate (its transform will not come, though a later
/// one's did) is not waited for: before, mapping stalled until the gate's queue overflowed
/// (faults.test, a clock jump back). One that can leave now goes on at once, in order.
TEST(InOrderRelease, AnEarlierMessageThatCannotLeaveAnyMoreIsNotWaitedFor) {
  std::string stuck = "a";
  InOrderRelease<double, std::string> order(
      10, [&stuck](const std::string& name) { return name != stuck; });
  order.entered(1.0, "a");
  order.entered(2.0, "b");
  order.entered(3.0, "c");
  EXPECT_EQ(order.left(2.0, "b"), Names{"b"});  // "a" cannot leave: "b" goes on
  EXPECT_EQ(order.inGate(), 1u);                // "c" (later) is still in the gate
  stuck = "none";
  order.entered(4.0, "d");
  order.entered(5.0, "e");
  // "c" and "d" could leave now: they go before "e" without waiting for the gate ...
  EXPECT_EQ(order.left(5.0, "e"), (Names{"c", "d", "e"}));
  EXPECT_EQ(order.inGate(), 0u);
  // ... whose answers for them, when they come, are ignored.
  EXPECT_EQ(order.left(4.0, "d"), Names{});
  bool handed_on = false;
  EXPECT_EQ(order.dropped(3.0, "c", &handed_on), Names{});
  EXPECT_TRUE(handed_on);
  EXPECT_EQ(order.held(), 0u);
}

/// tf2_ros 0.7's MessageFilter can lose its answer for a message (the transform request fires
/// before the message is queued): a message the gate never lets out although it could leave
/// goes on at the next sweep, and a gate that gives up on it later is told it was handed on.
TEST(InOrderRelease, SweepHandsOnWhatCouldLeaveAndForgetsWhatNeverWill) {
  std::vector<std::string> can = {"b", "d"};
  InOrderRelease<double, std::string> order(10, [&can](const std::string& name) {
    return std::find(can.begin(), can.end(), name) != can.end();
  });
  order.entered(1.0, "a");  // never can: before "b", forgotten
  order.entered(2.0, "b");
  order.entered(3.0, "c");  // cannot yet: before "d", which can, so it never will
  order.entered(4.0, "d");
  order.entered(5.0, "e");  // after the last that can: it still waits
  EXPECT_EQ(order.sweep(), (Names{"b", "d"}));
  EXPECT_EQ(order.inGate(), 1u);
  EXPECT_EQ(order.sweep(), Names{});  // "e" cannot leave yet
  can.push_back("e");
  EXPECT_EQ(order.sweep(), Names{"e"});
  EXPECT_EQ(order.left(2.0, "b"), Names{});  // the gate's late answers
  EXPECT_EQ(order.left(5.0, "e"), Names{});
  bool handed_on = true;
  EXPECT_EQ(order.dropped(1.0, "a", &handed_on), Names{});  // the gate gives up on "a"
  EXPECT_FALSE(handed_on);
  EXPECT_EQ(order.dropped(4.0, "d", &handed_on), Names{});
  EXPECT_TRUE(handed_on);
}

/// Without a CanLeaveNow test sweep does nothing: messages wait for the gate's answers.
TEST(InOrderRelease, SweepWithoutATestLeavesTheGateToAnswer) {
  InOrderRelease<double, std::string> order(10);
  order.entered(1.0, "a");
  EXPECT_EQ(order.sweep(), Names{});
  EXPECT_EQ(order.inGate(), 1u);
  EXPECT_EQ(order.left(1.0, "a"), Names{"a"});
}

/// The answers never given (the lost requests) are remembered for at most 2 max_held messages.
TEST(InOrderRelease, MessagesHandedOnEarlyAreRememberedBoundedly) {
  InOrderRelease<double, std::string> order(2, [](const std::string&) { return true; });
  for (int i = 0; i < 10; ++i) order.entered(i, std::to_string(i));
  EXPECT_EQ(order.sweep().size(), 10u);
  // The oldest six were forgotten: the gate's late answer for "0" is handed on again (as
  // before this bound existed, a message the gate answers for that never entered passes).
  EXPECT_EQ(order.left(0.0, "0"), Names{"0"});
  EXPECT_EQ(order.left(9.0, "9"), Names{});  // still remembered
}

/// tf grows on its own thread while a sweep tests the messages: the test goes from the latest
/// to the earliest, so an earlier message is never found unable to leave after a later one was
/// found able (it would be forgotten, then let out after the later one by the gate).
TEST(InOrderRelease, ASweepDuringATfUpdateKeepsTheOrder) {
  int calls = 0;
  // The first test sees the old buffer (nothing can leave), every later one the new buffer.
  InOrderRelease<double, std::string> order(10, [&calls](const std::string&) {
    return calls++ > 0;
  });
  order.entered(1.0, "a");
  order.entered(2.0, "b");
  // Latest first: "b" is tested on the old buffer and stays, "a" on the new one and goes.
  // (Earliest first would forget "a", hand on "b", and the gate would let "a" out after it.)
  EXPECT_EQ(order.sweep(), Names{"a"});
  EXPECT_EQ(order.inGate(), 1u);
  EXPECT_EQ(order.sweep(), Names{"b"});
}

/// Two messages of one stamp: one handed on early, the other answered by the gate; each answer
/// finds its own message. clear() forgets the early ones too.
TEST(InOrderRelease, EarlyAndAnsweredMessagesOfOneStampAndClear) {
  std::string can = "a";
  InOrderRelease<double, std::string> order(
      10, [&can](const std::string& name) { return name == can; });
  order.entered(1.0, "a");
  order.entered(1.0, "a2");
  EXPECT_EQ(order.sweep(), Names{"a"});  // "a2" (same stamp, not later) still waits
  EXPECT_EQ(order.left(1.0, "a2"), Names{"a2"});
  EXPECT_EQ(order.left(1.0, "a"), Names{});  // the late answer for the early one
  order.entered(2.0, "b");
  can = "b";
  EXPECT_EQ(order.sweep(), Names{"b"});
  order.clear();
  // After a reset the gate's late answer for "b" is a message never entered: handed on (the
  // subscriber's reset count keeps it from the pipeline).
  EXPECT_EQ(order.left(2.0, "b"), Names{"b"});
}

// core::InOrderRelease: messages that leave a tf gate out of order are handed on in stamp order.

#include <gtest/gtest.h>

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
/// (faults.test, a clock jump back).
TEST(InOrderRelease, AnEarlierMessageThatCannotLeaveAnyMoreIsNotWaitedFor) {
  std::string stuck = "a";
  InOrderRelease<double, std::string> order(
      10, [&stuck](const std::string& name) { return name != stuck; });
  order.entered(1.0, "a");
  order.entered(2.0, "b");
  order.entered(3.0, "c");
  EXPECT_EQ(order.left(2.0, "b"), Names{"b"});  // "a" cannot leave: "b" goes on
  EXPECT_EQ(order.inGate(), 1u);                // "c" still waits in the gate
  stuck = "none";
  order.entered(4.0, "d");
  order.entered(5.0, "e");
  EXPECT_EQ(order.left(5.0, "e"), Names{});  // "d" may still leave: "e" waits for it
  EXPECT_EQ(order.left(4.0, "d"), Names{});  // now "c" (3.0, may still leave) holds both
  EXPECT_EQ(order.left(3.0, "c"), (Names{"c", "d", "e"}));
}

// EventQueue (rollback/session_core.h): the one bounded event stream both sessions use.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "rollback/session_core.h"

namespace lockroll::rollback {
namespace {

using Kind = SessionEvent::Kind;

TEST(EventQueue, EventsComeOutInOrderThenNone) {
    EventQueue q;
    SessionEvent e;
    EXPECT_FALSE(q.pop(e));
    q.push({Kind::Synchronized, 1, 0, 10, "start"});
    q.push({Kind::Disconnected, 2, 40, 20, "timed out"});
    ASSERT_TRUE(q.pop(e));
    EXPECT_EQ(e.kind, Kind::Synchronized);
    EXPECT_EQ(e.detail, "start");
    ASSERT_TRUE(q.pop(e));
    EXPECT_EQ(e.kind, Kind::Disconnected);
    EXPECT_EQ(e.peer, 2);
    EXPECT_EQ(e.frame, 40u);
    EXPECT_EQ(e.at_us, 20u);
    EXPECT_FALSE(q.pop(e));
    EXPECT_EQ(q.dropped(), 0u);
}

// An owner that never drains cannot grow a session without bound; the oldest events go, counted,
// and the newest (how the session ended) is kept.
TEST(EventQueue, FullQueueDropsTheOldestAndCountsIt) {
    EventQueue q;
    const std::size_t extra = 10;
    for (std::size_t i = 0; i < EventQueue::kCapacity + extra; ++i)
        q.push({Kind::Interrupted, 0, static_cast<std::uint32_t>(i), i, ""});
    q.push({Kind::Failed, 0, 99999, 0, "the end"});
    EXPECT_EQ(q.size(), EventQueue::kCapacity);
    EXPECT_EQ(q.dropped(), extra + 1);
    SessionEvent e;
    ASSERT_TRUE(q.pop(e));
    EXPECT_EQ(e.frame, extra + 1);  // the first kept
    SessionEvent last;
    while (q.pop(e)) last = e;
    EXPECT_EQ(last.kind, Kind::Failed);
    EXPECT_EQ(last.detail, "the end");
}

TEST(EventQueue, EveryKindHasAName) {
    for (int k = 0; k <= static_cast<int>(Kind::DesyncReport); ++k)
        EXPECT_STRNE(event_name(static_cast<Kind>(k)), "unknown") << "kind " << k;
}

// Reasons are switched on by name outside C++ (the C ABI, logs): each has its own, and a value
// past the last is "unknown", never another's name.
TEST(EventQueue, EveryReasonHasADistinctName) {
    using Reason = SessionEvent::Reason;
    std::set<std::string> names;
    for (int r = 0; r <= kLastReason; ++r) {
        const std::string name = reason_name(static_cast<Reason>(r));
        EXPECT_NE(name, "unknown") << "reason " << r;
        EXPECT_TRUE(names.insert(name).second) << "reason " << r << " repeats " << name;
    }
    EXPECT_STREQ(reason_name(Reason::None), "none");
    EXPECT_STREQ(reason_name(Reason::TimedOutTwoPlayerRule), "timed_out_two_player_rule");
    EXPECT_STREQ(reason_name(static_cast<Reason>(kLastReason + 1)), "unknown");
}

TEST(EventQueue, AnEventKeepsItsReason) {
    EventQueue q;
    q.push({Kind::Disconnected, 2, 5, 0, "timed out", SessionEvent::Reason::TimedOut});
    SessionEvent e;
    ASSERT_TRUE(q.pop(e));
    EXPECT_EQ(e.reason, SessionEvent::Reason::TimedOut);
    EXPECT_EQ(e.detail, "timed out");
}

}  // namespace
}  // namespace lockroll::rollback

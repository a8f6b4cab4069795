// SlotView (rollback/slot_view.h) on its own: a slot changing hands starts its per-epoch flags
// over, and keeps the handoff backoff that belongs to the slot.
#include "rollback/slot_view.h"

#include <gtest/gtest.h>

namespace lockroll::rollback {
namespace {

SlotView everything_set() {
    SlotView v;
    v.authoring = true;
    v.neutral_reported = true;
    v.handoff = 77;
    v.handed_off_by_me = true;
    v.kick_vote = true;
    v.pending_since_us = 5;
    v.lapsed = true;
    v.lapses = 2;
    v.next_handoff_us = 9'000'000;
    return v;
}

TEST(SlotView, NewEpochClearsEveryPerEpochFlag) {
    SlotView v = everything_set();
    v.new_epoch();
    EXPECT_FALSE(v.authoring);
    EXPECT_FALSE(v.neutral_reported);
    EXPECT_FALSE(v.handed_off_by_me);
    EXPECT_FALSE(v.kick_vote);
    EXPECT_EQ(v.pending_since_us, 0u);
    EXPECT_FALSE(v.lapsed);
}

TEST(SlotView, NewEpochKeepsTheHandoffBackoffAndFrame) {
    SlotView v = everything_set();
    v.new_epoch();
    EXPECT_EQ(v.lapses, 2);
    EXPECT_EQ(v.next_handoff_us, 9'000'000u);
    EXPECT_EQ(v.handoff, 77u);
}

}  // namespace
}  // namespace lockroll::rollback

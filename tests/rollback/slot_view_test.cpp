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
    v.restart_claim.claim(100, 0, 50);
    v.pending_since_us = 5;
    v.lapsed = true;
    v.maker = 1;
    v.orphaned = true;
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
    EXPECT_FALSE(v.restart_claim.stands(0)) << "a claim against the slot's previous process";
    EXPECT_EQ(v.pending_since_us, 0u);
    EXPECT_FALSE(v.lapsed);
    EXPECT_EQ(v.maker, kNoSlot);
    EXPECT_FALSE(v.orphaned);
}

TEST(SlotView, NewEpochKeepsTheHandoffBackoffAndFrame) {
    SlotView v = everything_set();
    v.new_epoch();
    EXPECT_EQ(v.lapses, 2);
    EXPECT_EQ(v.next_handoff_us, 9'000'000u);
    EXPECT_EQ(v.handoff, 77u);
}

constexpr std::uint64_t kDisconnect = 1'000'000;

// A slot handed over at frame 10: frames 0..9 are the owner's neutral input, flagged absent.
InputQueue handed_over() {
    InputQueue q(1, 64);
    const std::uint8_t zero = 0;
    for (std::uint32_t f = 0; f < 10; ++f) q.add_confirmed(f, std::span(&zero, 1), true);
    return q;
}

TEST(SlotView, AHandoffWhoseStreamNeverStartsLapsesOnceAfterDisconnectUs) {
    SlotView v;
    const InputQueue q = handed_over();
    using W = SlotView::Watch;
    EXPECT_EQ(v.watch_handoff(true, q, 5, 100, kDisconnect), W::Nothing) << "not needed yet: we are before its end";
    EXPECT_EQ(v.pending_since_us, 0u);
    EXPECT_EQ(v.watch_handoff(true, q, 10, 100, kDisconnect), W::Nothing);
    EXPECT_EQ(v.watch_handoff(true, q, 10, 100 + kDisconnect - 1, kDisconnect), W::Nothing);
    EXPECT_EQ(v.watch_handoff(true, q, 10, 100 + kDisconnect, kDisconnect), W::Lapsed);
    EXPECT_TRUE(v.lapsed);
    EXPECT_TRUE(v.lapse_vote);
    EXPECT_EQ(v.watch_handoff(true, q, 10, 200 + kDisconnect, kDisconnect), W::Nothing) << "voted once";
    EXPECT_EQ(SlotView{}.watch_handoff(true, q, 10, 100, 0), W::Nothing) << "disconnect_us 0: never";
}

TEST(SlotView, ItsOwnStreamStartingEndsTheWatchAndTheBackoff) {
    SlotView v;
    v.lapses = 2;
    InputQueue q = handed_over();
    EXPECT_EQ(v.watch_handoff(true, q, 10, 100, kDisconnect), SlotView::Watch::Nothing);
    EXPECT_NE(v.pending_since_us, 0u);
    const std::uint8_t one = 1;
    q.add_confirmed(10, std::span(&one, 1));
    EXPECT_EQ(v.watch_handoff(true, q, 11, 100 + 2 * kDisconnect, kDisconnect), SlotView::Watch::Nothing)
        << "it never lapsed: no vote to withdraw";
    EXPECT_EQ(v.pending_since_us, 0u);
    EXPECT_EQ(v.lapses, 0);
}

// A joiner that loads just past the deadline plays: the vote its lapse cast is withdrawn (once),
// while the lapse itself stays the reason (and backs off the next handoff) should the drop come.
TEST(SlotView, ItsOwnStreamStartingAfterALapseWithdrawsTheVote) {
    SlotView v;
    InputQueue q = handed_over();
    EXPECT_EQ(v.watch_handoff(true, q, 10, 100, kDisconnect), SlotView::Watch::Nothing);
    EXPECT_EQ(v.watch_handoff(true, q, 10, 100 + kDisconnect, kDisconnect), SlotView::Watch::Lapsed);
    const std::uint8_t one = 1;
    q.add_confirmed(10, std::span(&one, 1));
    EXPECT_EQ(v.watch_handoff(true, q, 11, 200 + kDisconnect, kDisconnect), SlotView::Watch::Started);
    EXPECT_FALSE(v.lapse_vote);
    EXPECT_TRUE(v.lapsed);
    EXPECT_EQ(v.watch_handoff(true, q, 12, 300 + kDisconnect, kDisconnect), SlotView::Watch::Nothing) << "withdrawn once";
}

// Its maker left (MembershipChanges::drop_slot): nobody can serve the handoff any more. It lapses
// as soon as it is pending, and its drop does not back the next handoff off.
TEST(SlotView, AnOrphanedHandoffLapsesAtOnceAndDoesNotBackOff) {
    SlotView v;
    v.lapses = 1;  // an earlier lapse's backoff, long over
    v.next_handoff_us = 50;
    v.orphaned = true;
    const InputQueue q = handed_over();
    using W = SlotView::Watch;
    EXPECT_EQ(v.watch_handoff(true, q, 5, 100, kDisconnect), W::Nothing) << "not needed yet: still no vote";
    EXPECT_EQ(v.watch_handoff(true, q, 10, 200, kDisconnect), W::Lapsed);
    EXPECT_TRUE(v.lapse_vote);
    v.dropped(300, kDisconnect);
    EXPECT_EQ(v.next_handoff_us, 50u);
    EXPECT_EQ(v.lapses, 1);
    EXPECT_FALSE(v.orphaned) << "per epoch";
    EXPECT_EQ(SlotView{}.watch_handoff(true, q, 10, 100, 0), W::Nothing) << "disconnect_us 0: never, orphaned or not";
}

TEST(SlotView, LapsedHandoffsBackOffTwoFourThenEightTimes) {
    SlotView v;
    std::uint64_t now = 0;
    for (std::uint64_t factor : {2, 4, 8, 8}) {
        v.lapsed = true;
        v.dropped(now, kDisconnect);
        EXPECT_EQ(v.next_handoff_us, now + factor * kDisconnect);
        EXPECT_FALSE(v.lapsed);
        now += 10;
    }
    v.dropped(now, kDisconnect);
    EXPECT_EQ(v.next_handoff_us, now - 10 + 8 * kDisconnect) << "a drop that was no lapse keeps the backoff";
}

}  // namespace
}  // namespace lockroll::rollback

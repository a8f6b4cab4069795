// InputAuthority on its own: which inputs of a running slot a relay wrote, the owner's copy
// verifying or contradicting them, and the relay counted and ignored (issue 21). Plus the one
// place a stored input may change: InputQueue::replace_confirmed.
#include <gtest/gtest.h>

#include <array>

#include "rollback/input_authority.h"
#include "rollback/input_queue.h"

namespace lockroll::rollback {
namespace {

TEST(InputAuthority, NothingRelayedNothingUnverified) {
    InputAuthority a(3, 4);
    EXPECT_FALSE(a.first_unverified());
    EXPECT_FALSE(a.relay_of(1, 0));
    EXPECT_FALSE(a.ignored(2));
    EXPECT_EQ(a.disagreements(2), 0u);
}

TEST(InputAuthority, OwnersEqualCopyVerifies) {
    InputAuthority a(3, 4);
    for (std::uint32_t f = 10; f < 13; ++f) a.note_relayed(1, f, 2);
    EXPECT_EQ(a.first_unverified(), 10u);
    EXPECT_EQ(a.relay_of(1, 11), 2u);
    a.verified(1, 11);  // any order: the middle record goes
    EXPECT_FALSE(a.relay_of(1, 11));
    EXPECT_EQ(a.first_unverified(11), 12u);
    a.note_relayed(1, 11, 2);  // older than the newest record: not recorded again
    EXPECT_FALSE(a.relay_of(1, 11));
    a.verified(1, 10);
    a.verified(1, 12);
    EXPECT_FALSE(a.first_unverified());
    EXPECT_FALSE(a.ignored(2));
}

TEST(InputAuthority, OwnersDifferentCopyCountsAndIgnoresTheRelayOncePerFrame) {
    InputAuthority a(3, 4);
    a.note_relayed(1, 5, 2);
    a.note_relayed(1, 6, 2);
    EXPECT_TRUE(a.owner_disagrees(1, 5, true));
    EXPECT_EQ(a.disagreements(2), 1u);
    EXPECT_TRUE(a.ignored(2));
    EXPECT_FALSE(a.relay_of(1, 5)) << "replaced by the owner's: no record left";
    EXPECT_EQ(a.first_unverified(), 6u);
    // A confirmed frame already rests on frame 6: the relayed input stands, the record stays
    // (marked) so the owner's resends are not blamed, and it no longer holds confirmation.
    EXPECT_TRUE(a.owner_disagrees(1, 6, false));
    EXPECT_FALSE(a.owner_disagrees(1, 6, false)) << "a resend of the same frame counts once";
    EXPECT_EQ(a.disagreements(2), 2u);
    EXPECT_EQ(a.relay_of(1, 6), 2u);
    EXPECT_FALSE(a.first_unverified());
    EXPECT_FALSE(a.owner_disagrees(1, 7, true)) << "no record: nothing to settle";
}

// Two relays disagree about a frame (one held, the other disputes it): the owner settles it.
// Verified, the disputer contradicted the owner and is counted; contradicted, the held relay
// is, and the disputer is not (its bytes were not kept: they may have been the owner's).
TEST(InputAuthority, ADisputerIsCountedWhenTheOwnerVerifiesTheHeldClaim) {
    InputAuthority a(4, 4);
    a.note_relayed(1, 5, 3);
    a.dispute(1, 5, 2);
    a.dispute(1, 5, 3);  // the held relay itself: no dispute
    a.dispute(1, 6, 2);  // no record: nothing to dispute
    EXPECT_EQ(a.first_unverified(), 5u) << "a disputed claim still waits for the owner";
    EXPECT_FALSE(a.ignored(2));
    EXPECT_EQ(a.verified(1, 5), std::uint64_t{1} << 2);
    EXPECT_EQ(a.disagreements(2), 1u);
    EXPECT_TRUE(a.ignored(2));
    EXPECT_EQ(a.disagreements(3), 0u);
    EXPECT_FALSE(a.ignored(3));
    EXPECT_EQ(a.verified(1, 5), 0u) << "settled once";

    a.note_relayed(1, 7, 2);
    a.dispute(1, 7, 3);
    EXPECT_TRUE(a.owner_disagrees(1, 7, true));
    EXPECT_EQ(a.disagreements(2), 2u);
    EXPECT_EQ(a.disagreements(3), 0u);
}

TEST(InputAuthority, FirstUnverifiedLooksOnlyFromAFrameOnAndAcrossSlots) {
    InputAuthority a(4, 4);
    a.note_relayed(1, 3, 2);
    a.note_relayed(1, 9, 2);
    a.note_relayed(3, 7, 0);
    EXPECT_EQ(a.first_unverified(), 3u);
    EXPECT_EQ(a.first_unverified(4), 7u);
    EXPECT_EQ(a.first_unverified_of(1, 4), 9u);
    EXPECT_FALSE(a.first_unverified(10));
}

TEST(InputAuthority, TwoAgreeingRelaysVouchOneRelayTwiceDoesNot) {
    InputAuthority a(4, 4);
    a.note_relayed(0, 8, 1);
    a.vouch(0, 8, 1);
    EXPECT_EQ(a.first_unverified(), 8u) << "the same relay again proves nothing";
    a.vouch(0, 8, 2);
    EXPECT_FALSE(a.first_unverified()) << "two relays agree: at least one is honest";
    EXPECT_EQ(a.relay_of(0, 8), 1u) << "the record stays: the owner's copy still settles it";
    EXPECT_TRUE(a.owner_disagrees(0, 8, true));
    EXPECT_TRUE(a.ignored(1));
}

TEST(InputAuthority, RecordsAreInOrderAndForgottenWithTheQueue) {
    InputAuthority a(2, 2);
    a.note_relayed(1, 4, 0);
    a.note_relayed(1, 4, 0);  // repeated: no second record
    a.note_relayed(1, 2, 0);  // older: none either
    a.note_relayed(1, 5, 0);
    a.forget_before(1, 5);
    EXPECT_FALSE(a.relay_of(1, 4));
    EXPECT_EQ(a.first_unverified(), 5u);
    a.reset_slot(1);
    EXPECT_FALSE(a.first_unverified());
    a.note_relayed(0, 1, 1);
    a.reset_all();
    EXPECT_FALSE(a.first_unverified());
}

TEST(InputAuthority, ARelayContradictingTheOwnersStreamIsCounted) {
    InputAuthority a(3, 3);
    a.relay_disagrees(2);
    EXPECT_EQ(a.disagreements(2), 1u);
    EXPECT_TRUE(a.ignored(2));
    EXPECT_FALSE(a.ignored(1));
    a.relay_disagrees(9);  // out of range: nothing
    EXPECT_FALSE(a.ignored(9));
    a.note_relayed(7, 0, 1);  // slot out of range: nothing
    EXPECT_FALSE(a.first_unverified());
}

TEST(InputQueueReplace, ReplacesOnlyAStoredFrame) {
    InputQueue q(2, 8);
    const std::array<std::uint8_t, 2> a{1, 2}, b{3, 4};
    ASSERT_EQ(q.add_confirmed(0, a), InputQueue::Add::Stored);
    ASSERT_EQ(q.add_confirmed(1, a, true), InputQueue::Add::Stored);
    EXPECT_FALSE(q.replace_confirmed(2, b)) << "not stored yet";
    EXPECT_FALSE(q.replace_confirmed(0, std::span(b).first(1))) << "wrong size";
    EXPECT_TRUE(q.replace_confirmed(1, b));
    EXPECT_EQ(q.confirmed(1)[0], 3);
    EXPECT_FALSE(q.confirmed_absent(1));
    EXPECT_EQ(q.last_confirmed()[1], 4);
    EXPECT_FALSE(q.last_absent());
    EXPECT_EQ(q.add_confirmed(1, b), InputQueue::Add::Duplicate);
    q.discard_before(1);
    EXPECT_FALSE(q.replace_confirmed(0, b)) << "below the floor";
}

}  // namespace
}  // namespace lockroll::rollback

// Membership (rollback/membership.h) on its own: when the votes make a running slot leave the
// view, and which votes count at all (issue 21: no peer's word alone drops another player).
#include "rollback/membership.h"

#include <gtest/gtest.h>

#include <initializer_list>

namespace lockroll::rollback {
namespace {

// Every voter in `voters` says `slot` is gone (the epoch it would leave into).
void all_vote_gone(Membership& m, std::initializer_list<PlayerId> voters, PlayerId slot) {
    for (PlayerId v : voters)
        EXPECT_EQ(m.vote(v, slot, Vote::Gone, static_cast<std::uint8_t>(m.epoch(slot) + 1)), Tally::Counted)
            << "voter " << v << " about " << slot;
}

// Drops whatever the votes decide, as the session does, until nothing more is decided.
void settle(Membership& m) {
    for (PlayerId s = m.next_gone(); s < static_cast<PlayerId>(m.players()); s = m.next_gone()) m.leave(s);
}

TEST(Membership, StartsWithEveryoneRunningAndNoVotes) {
    const Membership m(4, 0, TwoPlayerRule::PlayOnAlone);
    EXPECT_EQ(m.running_voters(), 4);
    EXPECT_EQ(m.majority_size(), 3);
    EXPECT_EQ(Membership(3, 0, TwoPlayerRule::PlayOnAlone).majority_size(), 2);
    EXPECT_EQ(Membership(8, 0, TwoPlayerRule::PlayOnAlone).majority_size(), 5);
    EXPECT_EQ(Membership(2, 0, TwoPlayerRule::PlayOnAlone).majority_size(), 1);
    EXPECT_EQ(Membership(2, 0, TwoPlayerRule::NoDrop).majority_size(), 2);
    for (PlayerId s = 0; s < 4; ++s) {
        EXPECT_TRUE(m.running(s));
        EXPECT_EQ(m.epoch(s), 0);
        EXPECT_EQ(m.gone_votes(s), 0);
        EXPECT_FALSE(m.decided_gone(s));
        EXPECT_EQ(m.advertised_state(s), SlotState::Running);
    }
    EXPECT_EQ(m.next_gone(), 4u);
    EXPECT_FALSE(m.partitioned());
}

TEST(Membership, TwoPlayersPlayOnAloneTheLocalVoteSuffices) {
    Membership m(2, 0, TwoPlayerRule::PlayOnAlone);
    EXPECT_EQ(m.vote_local(1, true), Tally::Counted);
    EXPECT_TRUE(m.decided_gone(1));
    EXPECT_FALSE(m.partitioned());
    m.leave(1);
    EXPECT_EQ(m.state(1), SlotState::Disconnected);
    EXPECT_EQ(m.epoch(1), 1);
    EXPECT_EQ(m.running_voters(), 1);
}

// Issue 21: each side of a view of two decides for itself. The other's vote about this
// process's slot is counted (it is the other's word) but never drops it: only this side's own
// vote drops the other. Before the rule one vote of the other's was a majority about us.
TEST(Membership, TwoPlayersTheOthersVoteNeverDropsMyOwnSlot) {
    Membership m(2, 1, TwoPlayerRule::PlayOnAlone);
    EXPECT_EQ(m.vote(0, 1, Vote::Gone, 1), Tally::Counted);
    EXPECT_EQ(m.gone_votes(1), 1);
    EXPECT_FALSE(m.decided_gone(1));
    EXPECT_EQ(m.next_gone(), 2);
    // Our own vote drops the other, whatever it says about us.
    EXPECT_EQ(m.vote_local(0, true), Tally::Counted);
    EXPECT_TRUE(m.decided_gone(0));
    EXPECT_FALSE(m.decided_gone(1));
    EXPECT_EQ(m.next_gone(), 0);
}

// The same once a third slot's drop leaves a view of two: a vote counted in the view of three
// (not a majority there) does not become one about us.
TEST(Membership, ThreePlayersDownToTwoAStaleVoteAboutMeDropsNobody) {
    Membership m(3, 1, TwoPlayerRule::PlayOnAlone);
    m.vote(0, 1, Vote::Gone, 1);  // survivor 0 heard nothing from us for a while
    EXPECT_FALSE(m.decided_gone(1));
    m.vote_local(2, true);
    m.vote(0, 2, Vote::Gone, 1);
    ASSERT_EQ(m.next_gone(), 2);
    m.leave(2);
    EXPECT_EQ(m.running_voters(), 2);
    m.vote(0, 1, Vote::Gone, 1);  // a table sent before 0 heard us again, arriving late
    EXPECT_FALSE(m.decided_gone(1));
    EXPECT_EQ(m.next_gone(), 3);
}

// With three running voters the strict majority rule stands: two votes against us drop us.
TEST(Membership, ThreePlayersTwoVotesAgainstMeStillDropMe) {
    Membership m(3, 2, TwoPlayerRule::PlayOnAlone);
    m.vote(0, 2, Vote::Gone, 1);
    EXPECT_FALSE(m.decided_gone(2));
    m.vote(1, 2, Vote::Gone, 1);
    EXPECT_TRUE(m.decided_gone(2));
    EXPECT_EQ(m.next_gone(), 2);
}

TEST(Membership, TwoPlayersNoDropNobodyLeavesAndTheLoneOneIsPartitioned) {
    Membership m(2, 0, TwoPlayerRule::NoDrop);
    m.vote_local(1, true);
    EXPECT_FALSE(m.decided_gone(1));
    EXPECT_TRUE(m.partitioned());
    m.vote_local(1, false);  // heard again
    EXPECT_FALSE(m.partitioned());
    EXPECT_EQ(m.gone_votes(1), 0);
}

TEST(Membership, ThreePlayersOneKilledTwoOfThreeDropIt) {
    Membership m(3, 0, TwoPlayerRule::PlayOnAlone);
    EXPECT_EQ(m.vote_local(2, true), Tally::Counted);
    EXPECT_FALSE(m.decided_gone(2)) << "one vote of three is no majority";
    EXPECT_FALSE(m.partitioned()) << "0 still hears 1: two of three";
    EXPECT_EQ(m.advertised_state(2), SlotState::Disconnected) << "the table carries the vote";
    EXPECT_EQ(m.advertised_epoch(2), 1);
    EXPECT_EQ(m.vote(1, 2, Vote::Gone, 1), Tally::Counted);
    EXPECT_TRUE(m.decided_gone(2));
    EXPECT_EQ(m.next_gone(), 2u);
    m.leave(2);
    EXPECT_EQ(m.state(2), SlotState::Disconnected);
    EXPECT_EQ(m.epoch(2), 1);
    EXPECT_EQ(m.running_voters(), 2);
    EXPECT_FALSE(m.votes_any_gone()) << "the vote is spent with the drop";
    EXPECT_EQ(m.advertised_state(2), SlotState::Disconnected);
    EXPECT_EQ(m.advertised_epoch(2), 1);
}

TEST(Membership, ThreePlayersSplitTwoOneTheTwoDropTheOneTheOneDropsNobody) {
    // Each side as it sees it. The pair {0, 1}:
    Membership pair(3, 0, TwoPlayerRule::PlayOnAlone);
    pair.vote_local(2, true);
    pair.vote(1, 2, Vote::Gone, 1);
    settle(pair);
    EXPECT_EQ(pair.state(2), SlotState::Disconnected);
    EXPECT_TRUE(pair.running(0));
    EXPECT_TRUE(pair.running(1));
    // The one, {2}: it votes both gone and hears neither.
    Membership one(3, 2, TwoPlayerRule::PlayOnAlone);
    one.vote_local(0, true);
    one.vote_local(1, true);
    settle(one);
    for (PlayerId s : {0u, 1u}) EXPECT_TRUE(one.running(s)) << s;
    EXPECT_TRUE(one.partitioned());
    // After the heal it hears the pair's votes about itself: two of three, it was dropped.
    one.vote_local(0, false);
    one.vote_local(1, false);
    EXPECT_FALSE(one.partitioned());
    one.vote(0, 2, Vote::Gone, 1);
    EXPECT_FALSE(one.decided_gone(2));
    one.vote(1, 2, Vote::Gone, 1);
    EXPECT_TRUE(one.decided_gone(2));
}

TEST(Membership, FourPlayersOneKilledThreeOfFourDropIt) {
    Membership m(4, 0, TwoPlayerRule::PlayOnAlone);
    all_vote_gone(m, {0, 1}, 3);
    EXPECT_FALSE(m.decided_gone(3)) << "two of four is no strict majority";
    all_vote_gone(m, {2}, 3);
    EXPECT_TRUE(m.decided_gone(3));
    settle(m);
    EXPECT_EQ(m.state(3), SlotState::Disconnected);
    EXPECT_EQ(m.running_voters(), 3);
}

TEST(Membership, FourPlayersSplitTwoTwoNobodyIsDroppedOnEitherSide) {
    for (PlayerId local : {0u, 2u}) {
        Membership m(4, local, TwoPlayerRule::PlayOnAlone);
        const PlayerId mate = local == 0 ? 1 : 3;
        for (PlayerId far = 0; far < 4; ++far) {
            if (far == local || far == mate) continue;
            m.vote_local(far, true);
            m.vote(mate, far, Vote::Gone, static_cast<std::uint8_t>(m.epoch(far) + 1));
        }
        settle(m);
        for (PlayerId s = 0; s < 4; ++s) EXPECT_TRUE(m.running(s)) << "local " << local << " slot " << s;
        EXPECT_TRUE(m.partitioned()) << "local " << local;
        // Healed: the local voter hears everyone again and withdraws; the mate's votes alone
        // decide nothing and the partition is over.
        for (PlayerId far = 0; far < 4; ++far) {
            if (far == local || far == mate) continue;
            EXPECT_EQ(m.vote_local(far, false), Tally::Counted);
        }
        EXPECT_FALSE(m.partitioned());
        EXPECT_EQ(m.next_gone(), 4u);
    }
}

TEST(Membership, EightPlayersSplitFiveThreeTheFiveDropTheThree) {
    Membership five(8, 0, TwoPlayerRule::PlayOnAlone);
    for (PlayerId far : {5u, 6u, 7u}) all_vote_gone(five, {0, 1, 2, 3, 4}, far);
    EXPECT_FALSE(five.partitioned()) << "five of eight hear each other";
    settle(five);
    for (PlayerId s = 0; s < 8; ++s) EXPECT_EQ(five.running(s), s < 5) << s;
    EXPECT_EQ(five.running_voters(), 5);

    Membership three(8, 5, TwoPlayerRule::PlayOnAlone);
    for (PlayerId far : {0u, 1u, 2u, 3u, 4u}) all_vote_gone(three, {5, 6, 7}, far);
    settle(three);
    EXPECT_EQ(three.running_voters(), 8) << "three of eight drop nobody";
    EXPECT_TRUE(three.partitioned());
}

TEST(Membership, OneForgedVoteDropsNobody) {
    // Peer 2 says slot 1 is gone, in a newer epoch than ours: one voice of three.
    Membership m(3, 0, TwoPlayerRule::PlayOnAlone);
    EXPECT_EQ(m.vote(2, 1, Vote::Gone, 7), Tally::Counted);
    EXPECT_EQ(m.gone_votes(1), 1);
    EXPECT_FALSE(m.decided_gone(1));
    EXPECT_EQ(m.next_gone(), 3u);
    // Repeating it changes nothing; neither does a claim that the local slot is gone.
    EXPECT_EQ(m.vote(2, 1, Vote::Gone, 7), Tally::Repeated);
    EXPECT_EQ(m.vote(2, 0, Vote::Gone, 1), Tally::Counted);
    EXPECT_FALSE(m.decided_gone(0));
    // Withdrawn by its voter.
    EXPECT_EQ(m.vote(2, 1, Vote::Runs, 0), Tally::Counted);
    EXPECT_EQ(m.gone_votes(1), 0);
}

TEST(Membership, VotesOfAVoterThatIsNotRunningAreIgnored) {
    Membership m(4, 0, TwoPlayerRule::PlayOnAlone);
    m.leave(3);
    EXPECT_EQ(m.vote(3, 1, Vote::Gone, 1), Tally::NotAVoter);
    EXPECT_EQ(m.vote(9, 1, Vote::Gone, 1), Tally::NotAVoter) << "out of range";
    // A vote cast while running stops counting once the voter leaves; the three left then need
    // two votes of their own.
    Membership n(4, 0, TwoPlayerRule::PlayOnAlone);
    all_vote_gone(n, {3}, 1);
    n.leave(3);
    EXPECT_EQ(n.gone_votes(1), 0);
    all_vote_gone(n, {0}, 1);
    EXPECT_FALSE(n.decided_gone(1));
    all_vote_gone(n, {2}, 1);
    EXPECT_TRUE(n.decided_gone(1));
}

TEST(Membership, AVoteAboutOneselfSaysNothingNew) {
    Membership m(3, 0, TwoPlayerRule::PlayOnAlone);
    EXPECT_EQ(m.vote(1, 1, Vote::Gone, 1), Tally::AboutItself);
    EXPECT_EQ(m.vote_local(0, true), Tally::AboutItself);
    EXPECT_EQ(m.gone_votes(1), 0);
    EXPECT_EQ(m.gone_votes(0), 0);
}

TEST(Membership, StaleVotesAreIgnored) {
    Membership m(3, 0, TwoPlayerRule::PlayOnAlone);
    // Slot 2 left in epoch 1 and came back (handed over by the owner) in epoch 2.
    m.leave(2);
    m.set(2, SlotState::Running, 2);
    EXPECT_EQ(m.vote(1, 2, Vote::Gone, 1), Tally::Stale) << "gone at the old epoch: about its predecessor";
    EXPECT_EQ(m.vote(1, 2, Vote::Gone, 2), Tally::Stale) << "gone must name a newer epoch than the view's";
    EXPECT_EQ(m.vote(1, 2, Vote::Runs, 1), Tally::Stale);
    EXPECT_EQ(m.gone_votes(2), 0);
    EXPECT_EQ(m.vote(1, 2, Vote::Gone, 3), Tally::Counted);
    EXPECT_EQ(m.vote(1, 2, Vote::Runs, 2), Tally::Counted);
    // Epochs wrap: 1 is newer than 255.
    Membership w(3, 0, TwoPlayerRule::PlayOnAlone);
    w.set(2, SlotState::Running, 255);
    EXPECT_EQ(w.vote(1, 2, Vote::Gone, 0), Tally::Counted);
    EXPECT_EQ(w.vote(0, 2, Vote::Gone, 200), Tally::Stale);
}

TEST(Membership, AVoteOnASlotThatIsNotRunningIsIgnored) {
    Membership m(3, 0, TwoPlayerRule::PlayOnAlone);
    m.set(2, SlotState::Absent, 0);
    EXPECT_EQ(m.vote(1, 2, Vote::Gone, 1), Tally::NotRunning);
    EXPECT_EQ(m.running_voters(), 2);
    // With 2 absent, the view has two running players: the two-player rule applies.
    EXPECT_EQ(m.vote_local(1, true), Tally::Counted);
    EXPECT_TRUE(m.decided_gone(1));
}

TEST(Membership, AViewChangeForgetsTheVotesAboutTheSlotAndByIt) {
    Membership m(3, 0, TwoPlayerRule::PlayOnAlone);
    all_vote_gone(m, {1}, 2);
    all_vote_gone(m, {2}, 1);
    m.set(2, SlotState::Running, 5);  // a new process in slot 2
    EXPECT_EQ(m.gone_votes(2), 0);
    EXPECT_EQ(m.gone_votes(1), 0);
}

TEST(Membership, AProcessWithGuestsIsOneVoterAndItsGuestsFollowIt) {
    // Slots 0 and 1 on one couch (host 0), slot 2 alone: two processes.
    Membership b(3, 2, TwoPlayerRule::PlayOnAlone, {0, 0, 2});
    EXPECT_EQ(b.running_voters(), 2);
    EXPECT_EQ(b.vote_local(1, true), Tally::AboutAGuest);
    EXPECT_EQ(b.vote_local(0, true), Tally::Counted);
    EXPECT_TRUE(b.decided_gone(0)) << "two processes: the two-player rule";
    EXPECT_FALSE(b.decided_gone(1)) << "the guest leaves with its host, not by a vote";
    Membership a(3, 0, TwoPlayerRule::PlayOnAlone, {0, 0, 2});
    EXPECT_EQ(a.vote(1, 2, Vote::Gone, 1), Tally::NotAVoter) << "a guest has no voice of its own";
    EXPECT_EQ(a.vote(2, 1, Vote::Gone, 1), Tally::AboutAGuest);
    EXPECT_EQ(a.vote(0, 1, Vote::Gone, 1), Tally::AboutItself) << "a host about its own guest";
}

// Issue 21, "membership that cannot freeze": 3 players, slot 1 handed over to a joiner, slot 2
// killed before the joiner played. Counted as a voter, the joiner (which votes nothing yet) left
// the survivor 1 vote of the 2 it needed, partitioned for good. It is no voter until it plays:
// the view is two and the survivor's own vote drops the dead slot.
TEST(Membership, AJoinerIsNoVoterUntilItPlaysSoASurvivorOfAKillDropsTheDead) {
    Membership m(3, 0, TwoPlayerRule::PlayOnAlone);
    m.set(1, SlotState::Absent, 0);
    EXPECT_EQ(m.running_voters(), 2);
    m.hand_over(1, 1);
    EXPECT_TRUE(m.running(1));
    EXPECT_TRUE(m.joining(1));
    EXPECT_FALSE(m.is_voter(1));
    EXPECT_EQ(m.running_voters(), 2) << "the voter base is what it was before the handoff";
    EXPECT_EQ(m.majority_size(), 1);
    EXPECT_EQ(m.electorate(2), 2);
    EXPECT_EQ(m.vote_local(2, true), Tally::Counted);
    EXPECT_TRUE(m.decided_gone(2)) << "a view of two voters: the two-player rule";
    EXPECT_FALSE(m.partitioned());
    settle(m);
    EXPECT_EQ(m.state(2), SlotState::Disconnected);
    EXPECT_TRUE(m.running(1)) << "the joiner stays; it may still load and play";
    EXPECT_EQ(m.running_voters(), 1);
    // Its stream starts: it votes and counts from now on.
    m.started(1);
    EXPECT_FALSE(m.joining(1));
    EXPECT_EQ(m.running_voters(), 2);
}

// The same with the joiner counted, as before the fix: no drop, and the survivor is partitioned.
TEST(Membership, ARunningSlotThatIsNotJoiningStillCountsAsAVoter) {
    Membership m(3, 0, TwoPlayerRule::PlayOnAlone);
    m.set(1, SlotState::Running, 1);  // a table or snapshot: nothing says a joiner there
    EXPECT_FALSE(m.joining(1));
    m.vote_local(2, true);
    m.vote_local(1, true);
    EXPECT_FALSE(m.decided_gone(2));
    EXPECT_TRUE(m.partitioned());
    m.hand_over(1, 2);
    m.set(1, SlotState::Running, 3);
    EXPECT_FALSE(m.joining(1)) << "set() is no join";
}

// A joiner votes nothing until it plays (a forged joiner cannot vote either), and once it plays
// its word counts like any voter's.
TEST(Membership, AJoinersVotesCountOnlyOnceItPlays) {
    Membership m(4, 0, TwoPlayerRule::PlayOnAlone);
    m.hand_over(3, 1);
    EXPECT_EQ(m.vote(3, 2, Vote::Gone, 1), Tally::NotAVoter);
    EXPECT_EQ(m.gone_votes(2), 0);
    m.started(3);
    EXPECT_EQ(m.vote(3, 2, Vote::Gone, 1), Tally::Counted);
    EXPECT_EQ(m.gone_votes(2), 1);
}

// A handoff that lapses (SlotView::watch_handoff) is voted on with the joining slot in the
// denominator, as always for the slot voted on: beside two voters it needs both, and a lone
// survivor decides it by the two-player rule (under NoDrop it does not, and is partitioned).
TEST(Membership, AJoinersLapsedHandoffCountsTheJoinerInItsOwnDecision) {
    Membership m(3, 0, TwoPlayerRule::PlayOnAlone);
    m.hand_over(1, 1);
    EXPECT_EQ(m.electorate(1), 3);
    m.vote_local(1, true);
    EXPECT_FALSE(m.decided_gone(1)) << "1 of 3";
    EXPECT_FALSE(m.partitioned()) << "0 hears 2: two of three";
    all_vote_gone(m, {2}, 1);
    EXPECT_TRUE(m.decided_gone(1));

    Membership alone(3, 0, TwoPlayerRule::PlayOnAlone);
    alone.leave(2);
    alone.hand_over(1, 1);
    alone.vote_local(1, true);
    EXPECT_TRUE(alone.decided_gone(1)) << "survivor and joiner: a view of two";
    Membership no_drop(3, 0, TwoPlayerRule::NoDrop);
    no_drop.leave(2);
    no_drop.hand_over(1, 1);
    no_drop.vote_local(1, true);
    EXPECT_FALSE(no_drop.decided_gone(1));
    EXPECT_TRUE(no_drop.partitioned()) << "as a survivor of two under no_drop";
}

// A partition is still found with a joiner in the view: 4 slots, slot 3 joining, the three
// voters split 1/2. The one hears no majority of the three voters; the two drop it.
TEST(Membership, APartitionBesideAJoinerIsStillDetected) {
    Membership one(4, 0, TwoPlayerRule::PlayOnAlone);
    one.hand_over(3, 1);
    one.vote_local(1, true);
    one.vote_local(2, true);
    EXPECT_FALSE(one.decided_gone(1));
    EXPECT_FALSE(one.decided_gone(2));
    EXPECT_TRUE(one.partitioned());
    Membership two(4, 1, TwoPlayerRule::PlayOnAlone);
    two.hand_over(3, 1);
    two.vote_local(0, true);
    EXPECT_EQ(two.vote(2, 0, Vote::Gone, 1), Tally::Counted);
    EXPECT_TRUE(two.decided_gone(0)) << "2 of the 3 voters";
    EXPECT_FALSE(two.partitioned());
}

}  // namespace
}  // namespace lockroll::rollback

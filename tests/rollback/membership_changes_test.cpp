// MembershipChanges (rollback/membership_changes.h) on its own, over a hand-built view, slots and
// links and a fake of the rest of the session (no session, no network): votes counted, a slot
// dropped only when a majority says so (its guests with it), our own slot kicked, silence and a
// lapsed handoff as our vote, a kick, Partitioned once per episode, a peer's table adopted.
#include "rollback/membership_changes.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "tests/rollback/fake_effects.h"

namespace lockroll::rollback {
namespace {

using Kind = SessionEvent::Kind;
using Reason = SessionEvent::Reason;
using testing::EffectsFixture;
constexpr std::uint64_t kInterrupt = 250'000;
constexpr std::uint64_t kDisconnect = 1'000'000;

// `players` slots, this session slot 0, and one spectator (the last peer id).
struct Fixture : EffectsFixture {
    SessionStats stats;
    MembershipChanges changes;

    explicit Fixture(int players, std::vector<PlayerId> hosts = {}, TwoPlayerRule rule = TwoPlayerRule::PlayOnAlone,
                     PlayerId local = 0)
        : EffectsFixture(players, local, std::move(hosts), rule, 1), changes(config, view, slots, links, stats, fake) {
        config.interrupt_us = kInterrupt;
        config.disconnect_us = kDisconnect;
    }
    // The voters named follow our proposal (rollback/drop_agreement.h): each promises our ballot
    // and accepts the slot we name, as a peer's reports would say, until the drop is applied.
    void agree(std::vector<PlayerId> voters, std::uint64_t now_us) {
        for (int round = 0; round < 3; ++round) {
            const AgreementReport ours = changes.agreement().report();
            if (ours.proposal == 0) return;
            for (PlayerId v : voters) {
                AgreementReport r;
                r.instance = ours.instance;
                r.promised = ours.proposal;
                if (ours.proposal_slot != kNoSlot) {
                    r.accepted = ours.proposal;
                    r.accepted_slot = ours.proposal_slot;
                }
                changes.heard_agreement(v, r);
            }
            changes.settle_membership(now_us);
        }
    }
    // The voters named report that they accepted `slot` under the first voter's first ballot.
    void others_chose(PlayerId slot, std::vector<PlayerId> voters, std::uint64_t now_us) {
        AgreementReport r;
        r.instance = view.view_id();
        r.promised = r.accepted = make_ballot(1, voters.front());
        r.accepted_slot = static_cast<std::uint8_t>(slot);
        for (PlayerId v : voters) changes.heard_agreement(v, r);
        changes.settle_membership(now_us);
    }
    // A peer's table drops `slot`, then hands it to a joiner at frame h: our stream of it is the
    // owner's neutral input up to h, and the joiner is no voter yet.
    void handed_over_by_a_table(PlayerId slot, std::uint32_t h, std::uint64_t now_us) {
        const std::vector<std::uint8_t> zero{0};
        changes.adopt_slot(slot, {static_cast<std::uint8_t>(slot), SlotState::Disconnected, 1, 0}, now_us);
        for (std::uint32_t fr = 0; fr < h; ++fr) fake.queues[slot].add_confirmed(fr, zero, true);
        changes.adopt_slot(slot, {static_cast<std::uint8_t>(slot), SlotState::Running, 2, 0}, now_us);
    }
    // Every peer but `silent` (and this session) heard now.
    void hear_all_but(PlayerId silent, std::uint64_t now_us) {
        for (std::size_t p = 1; p < links.size(); ++p)
            if (p != silent) links[p].mark_heard(now_us);
    }
};

TEST(MembershipChanges, OneVoteOfThreeDropsNobodyAMajorityDropsTheSlot) {
    Fixture f(3);
    f.changes.count_vote(1, 2, Vote::Gone, 1);
    f.changes.settle_membership(100);
    EXPECT_TRUE(f.view.running(2)) << "one voter of three is no majority";
    EXPECT_TRUE(f.fake.of(Kind::Disconnected).empty());
    EXPECT_EQ(f.stats.drop_votes_unheeded, 1u) << "a counted gone we do not share";

    f.view.vote_local(2, true);
    f.changes.settle_membership(200);
    EXPECT_TRUE(f.view.running(2)) << "a majority of votes proposes; the drop waits for the agreement";
    EXPECT_NE(f.changes.agreement().report().proposal, 0) << "our proposal";
    f.agree({1}, 200);
    EXPECT_EQ(f.view.state(2), SlotState::Disconnected);
    EXPECT_EQ(f.view.epoch(2), 1);
    const auto dropped = f.fake.of(Kind::Disconnected);
    ASSERT_EQ(dropped.size(), 1u);
    EXPECT_EQ(dropped[0].peer, 2);
    EXPECT_EQ(dropped[0].detail, "timed out, agreed by 2 of 3 players");
    EXPECT_EQ(dropped[0].reason, Reason::TimedOut);
    EXPECT_EQ(f.fake.changed_hands, std::vector<PlayerId>{2});
    EXPECT_EQ(f.fake.failed_peers, std::vector<PlayerId>{2});
    EXPECT_GT(f.fake.floor_moves, 0);
    EXPECT_FALSE(f.fake.failed);
}

TEST(MembershipChanges, AVoteInAnOldEpochIsIgnored) {
    Fixture f(3);
    f.view.set(2, SlotState::Running, 1);  // slot 2 rejoined: epoch 1
    f.changes.count_vote(1, 2, Vote::Gone, 1);  // "gone into epoch 1": about its previous process
    f.view.vote_local(2, true);
    f.changes.settle_membership(100);
    EXPECT_TRUE(f.view.running(2));
    EXPECT_EQ(f.stats.drop_votes_unheeded, 0u);
    f.changes.count_vote(1, 2, Vote::Gone, 2);
    f.changes.settle_membership(200);
    f.agree({1}, 200);
    EXPECT_EQ(f.view.state(2), SlotState::Disconnected);
}

TEST(MembershipChanges, AVoteWeShareIsNotUnheeded) {
    Fixture f(4);
    f.view.vote_local(3, true);
    f.changes.count_vote(1, 3, Vote::Gone, 1);
    EXPECT_EQ(f.stats.drop_votes_unheeded, 0u);
    f.changes.count_vote(1, 3, Vote::Gone, 1);  // repeated: not counted again
    f.changes.count_vote(2, 2, Vote::Gone, 1);  // about itself: ignored
    EXPECT_EQ(f.stats.drop_votes_unheeded, 0u);
}

TEST(MembershipChanges, TwoPlayersPlayOnAloneDropsOnOurVoteNoDropNever) {
    Fixture alone(2);
    alone.view.vote_local(1, true);
    alone.changes.settle_membership(100);
    EXPECT_EQ(alone.view.state(1), SlotState::Disconnected);
    ASSERT_EQ(alone.fake.of(Kind::Disconnected).size(), 1u);
    EXPECT_EQ(alone.fake.of(Kind::Disconnected)[0].detail,
              "timed out, by 1 of 2 votes (the two-player rule, play_on_alone: this process plays on alone)");
    EXPECT_EQ(alone.fake.of(Kind::Disconnected)[0].reason, Reason::TimedOutTwoPlayerRule);

    Fixture never(2, {}, TwoPlayerRule::NoDrop);
    never.view.vote_local(1, true);
    never.changes.settle_membership(100);
    EXPECT_TRUE(never.view.running(1));
    EXPECT_TRUE(never.fake.of(Kind::Disconnected).empty());
}

TEST(MembershipChanges, OurOwnSlotVotedGoneByAMajorityIsKicked) {
    Fixture f(3);
    f.changes.count_vote(1, 0, Vote::Gone, 1);
    f.changes.count_vote(2, 0, Vote::Gone, 1);
    f.changes.settle_membership(100);
    EXPECT_TRUE(f.fake.of(Kind::Kicked).empty()) << "votes are no drop until agreed";
    f.others_chose(0, {1, 2}, 100);
    const auto kicked = f.fake.of(Kind::Kicked);
    ASSERT_EQ(kicked.size(), 1u);
    EXPECT_EQ(kicked[0].peer, 0);
    EXPECT_EQ(kicked[0].frame, f.fake.shown);
    EXPECT_EQ(kicked[0].detail, "2 of 3 players agreed to drop this slot");
    EXPECT_EQ(kicked[0].reason, Reason::VotedOut);
    EXPECT_TRUE(f.fake.failed);
    EXPECT_TRUE(f.fake.of(Kind::Disconnected).empty()) << "nothing more once kicked";
}

// Issue 21: in a view of two each side decides for itself. The other's vote that our slot is
// gone (a table sent while it did not hear us, arriving late) is counted but kicks nobody; our
// own vote drops the other. Before the rule it was "1 of 2 players voted this slot gone".
TEST(MembershipChanges, TwoPlayersTheOthersVoteAboutUsKicksNobody) {
    Fixture f(2);
    f.changes.count_vote(1, 0, Vote::Gone, 1);
    f.changes.settle_membership(100);
    EXPECT_TRUE(f.fake.of(Kind::Kicked).empty());
    EXPECT_FALSE(f.fake.failed);
    EXPECT_TRUE(f.view.running(0));
    EXPECT_TRUE(f.view.running(1));
    f.view.vote_local(1, true);
    f.changes.settle_membership(200);
    EXPECT_TRUE(f.fake.of(Kind::Kicked).empty());
    EXPECT_EQ(f.view.state(1), SlotState::Disconnected);
    EXPECT_TRUE(f.view.running(0));
}

// A slot dropped from a view of three leaves two: a vote about us counted before (no majority
// of three) is no majority of two either.
TEST(MembershipChanges, ThreeDownToTwoAVoteAboutUsKicksNobody) {
    Fixture f(3);
    f.changes.count_vote(1, 0, Vote::Gone, 1);
    f.changes.count_vote(1, 2, Vote::Gone, 1);
    f.view.vote_local(2, true);
    f.changes.settle_membership(100);
    f.agree({1}, 100);
    EXPECT_EQ(f.view.state(2), SlotState::Disconnected);
    f.changes.count_vote(1, 0, Vote::Gone, 1);
    f.changes.settle_membership(200);
    EXPECT_TRUE(f.fake.of(Kind::Kicked).empty());
    EXPECT_FALSE(f.fake.failed);
    EXPECT_TRUE(f.view.running(0));
}

// A refusal "dropped from the match" is not the other's vote but its decision made: in a view of
// two it plays on alone without us (and its refusals are heard, so our silence never drops it):
// kicked, and the rejoin path applies. A stale one (about an older epoch of our slot) says
// nothing. With three players it is one vote, as before.
TEST(MembershipChanges, TwoPlayersARefusalAsDroppedKicksUsThreePlayersItIsOneVote) {
    Fixture two(2);
    two.view.set(0, SlotState::Running, 1);  // we rejoined: epoch 1
    two.changes.refused_as_dropped(1, 1, 100);  // about our previous process
    EXPECT_TRUE(two.fake.of(Kind::Kicked).empty());
    two.changes.refused_as_dropped(1, 2, 200);
    ASSERT_EQ(two.fake.of(Kind::Kicked).size(), 1u);
    EXPECT_EQ(two.fake.of(Kind::Kicked)[0].detail, "peer 1 dropped this slot (the two-player rule: it plays on alone)");
    EXPECT_TRUE(two.fake.failed);

    Fixture three(3);
    three.changes.refused_as_dropped(1, 1, 100);
    EXPECT_TRUE(three.fake.of(Kind::Kicked).empty());
    EXPECT_EQ(three.view.gone_votes(0), 1);
    three.changes.refused_as_dropped(2, 1, 200);
    ASSERT_EQ(three.fake.of(Kind::Kicked).size(), 1u);
    EXPECT_EQ(three.fake.of(Kind::Kicked)[0].detail, "2 of 3 players agreed to drop this slot")
        << "two refusals: both applied our drop, a majority's word";
}

TEST(MembershipChanges, AHostDroppedTakesItsGuests) {
    Fixture f(4, {0, 1, 1, 3});  // slot 2 is played by slot 1's process
    f.view.vote_local(1, true);
    f.changes.count_vote(3, 1, Vote::Gone, 1);
    f.changes.settle_membership(100);
    f.agree({3}, 100);
    const auto dropped = f.fake.of(Kind::Disconnected);
    ASSERT_EQ(dropped.size(), 2u);
    EXPECT_EQ(dropped[0].peer, 1);
    EXPECT_EQ(dropped[1].peer, 2);
    EXPECT_EQ(dropped[1].detail, "its host was dropped");
    EXPECT_EQ(dropped[0].reason, Reason::TimedOut) << "our vote and slot 3's";
    EXPECT_EQ(dropped[1].reason, Reason::HostDropped);
    EXPECT_FALSE(f.view.running(2));
}

TEST(MembershipChanges, SilenceIsOurVoteInterruptedOnceBefore) {
    Fixture f(3);
    f.hear_all_but(99, 0);
    f.fake.queues[2].add_confirmed(0, std::vector<std::uint8_t>{1});  // its own stream runs
    f.hear_all_but(2, kInterrupt);
    f.changes.check_silence(kInterrupt);
    ASSERT_EQ(f.fake.of(Kind::Interrupted).size(), 1u);
    EXPECT_EQ(f.fake.of(Kind::Interrupted)[0].peer, 2);
    EXPECT_EQ(f.fake.of(Kind::Interrupted)[0].reason, Reason::Silent);
    f.hear_all_but(2, kInterrupt + 1);
    f.changes.check_silence(kInterrupt + 1);
    EXPECT_EQ(f.fake.of(Kind::Interrupted).size(), 1u) << "once per silence";
    EXPECT_NE(f.view.vote_of(0, 2), Vote::Gone) << "not silent for disconnect_us yet";

    f.hear_all_but(2, kDisconnect);
    f.changes.check_silence(kDisconnect);
    EXPECT_EQ(f.view.vote_of(0, 2), Vote::Gone);
    EXPECT_TRUE(f.view.running(2)) << "our vote alone is no majority of three";
    f.changes.count_vote(1, 2, Vote::Gone, 1);
    f.hear_all_but(2, kDisconnect + 1);
    f.changes.check_silence(kDisconnect + 1);  // settles: our proposal
    f.agree({1}, kDisconnect + 1);
    EXPECT_EQ(f.view.state(2), SlotState::Disconnected);
    EXPECT_EQ(f.fake.of(Kind::Disconnected).at(0).detail, "timed out, agreed by 2 of 3 players");
}

TEST(MembershipChanges, ASilentSpectatorIsNoLongerServed) {
    Fixture f(3);
    f.hear_all_but(99, 0);
    f.hear_all_but(3, kDisconnect);
    f.changes.check_silence(kDisconnect);
    EXPECT_FALSE(f.links[3].welcomed);
    const auto gone = f.fake.of(Kind::Disconnected);
    ASSERT_EQ(gone.size(), 1u);
    EXPECT_EQ(gone[0].peer, 3);
    EXPECT_EQ(gone[0].detail, "spectator timed out");
    EXPECT_EQ(gone[0].reason, Reason::SpectatorTimedOut);
    for (PlayerId s = 0; s < 3; ++s) EXPECT_TRUE(f.view.running(s));
}

TEST(MembershipChanges, AHandoffWhoseStreamNeverStartsIsVotedGone) {
    Fixture f(3);
    const std::vector<std::uint8_t> zero{0};
    for (std::uint32_t fr = 0; fr < 10; ++fr) f.fake.queues[2].add_confirmed(fr, zero, true);  // the owner's neutral input
    f.fake.shown = 10;
    f.hear_all_but(99, 100);
    f.changes.check_silence(100);
    f.hear_all_but(99, 100 + kDisconnect - 1);
    f.changes.check_silence(100 + kDisconnect - 1);
    EXPECT_NE(f.view.vote_of(0, 2), Vote::Gone) << "stalled on it for less than disconnect_us";
    f.hear_all_but(99, 100 + kDisconnect);
    f.changes.check_silence(100 + kDisconnect);
    EXPECT_TRUE(f.slots[2].lapsed);
    EXPECT_EQ(f.view.vote_of(0, 2), Vote::Gone) << "heard all along, yet it does not play";
    f.changes.count_vote(1, 2, Vote::Gone, 1);
    f.changes.settle_membership(200 + kDisconnect);
    f.agree({1}, 200 + kDisconnect);
    EXPECT_EQ(f.fake.of(Kind::Disconnected).at(0).detail, "handoff lapsed, agreed by 2 of 3 players");
    EXPECT_EQ(f.fake.of(Kind::Disconnected).at(0).reason, Reason::HandoffLapsed);
}

// The joiner loads just past the deadline: its own inputs reach us before a majority dropped it.
// It plays, so the vote its lapse cast is withdrawn (it was kept until the drop, and the five-player
// freeze dropped joiners that had loaded 200 ms before; each one fetched a snapshot again). A kick
// stands.
TEST(MembershipChanges, ALapsedHandoffsVoteIsWithdrawnOnceItsStreamStarts) {
    for (const bool kicked : {false, true}) {
        SCOPED_TRACE(kicked ? "kicked too" : "lapsed only");
        Fixture f(3);
        const std::vector<std::uint8_t> zero{0}, one{1};
        for (std::uint32_t fr = 0; fr < 10; ++fr) f.fake.queues[2].add_confirmed(fr, zero, true);
        f.fake.shown = 10;
        f.hear_all_but(99, 100);
        f.changes.check_silence(100);
        f.hear_all_but(99, 100 + kDisconnect);
        f.changes.check_silence(100 + kDisconnect);
        ASSERT_EQ(f.view.vote_of(0, 2), Vote::Gone);
        if (kicked) f.changes.disconnect_player(2, 100 + kDisconnect);
        f.fake.queues[2].add_confirmed(10, one);  // its own first input
        f.fake.shown = 11;
        f.hear_all_but(99, 200 + kDisconnect);
        f.changes.check_silence(200 + kDisconnect);
        EXPECT_EQ(f.view.vote_of(0, 2) == Vote::Gone, kicked);
        EXPECT_TRUE(f.view.running(2));
        EXPECT_TRUE(f.fake.of(Kind::Disconnected).empty());
    }
}

// Issue 21: slot 3 was handed over by the owner (slot 0, the lowest running slot when slot 2, this
// session, learned of it) and the owner is dropped before the joiner's stream starts. Only the
// owner could serve that handoff, so it is orphaned: our vote comes as soon as we need the slot's
// input, not disconnect_us later, the drop says so, and its next handoff does not back off.
// Another player's drop orphans nothing: the handoff waits out disconnect_us as before.
TEST(MembershipChanges, TheOwnersDropVotesItsPendingHandoffGone) {
    for (const PlayerId dropped : {0u, 1u}) {
        SCOPED_TRACE("slot " + std::to_string(dropped) + " dropped");
        Fixture f(4, {}, TwoPlayerRule::PlayOnAlone, 2);
        const PlayerId other = dropped == 0 ? 1 : 0;
        const auto hear_all_but = [&](PlayerId silent, std::uint64_t now_us) {
            for (std::size_t p = 0; p < f.links.size(); ++p)
                if (p != silent && p != 2) f.links[p].mark_heard(now_us);
        };
        f.handed_over_by_a_table(3, 10, 60);
        ASSERT_TRUE(f.view.joining(3));
        EXPECT_EQ(f.slots[3].maker, 0u) << "the owner as this session sees it";
        f.fake.shown = 5;  // stalled on the dying slot before the handoff frame
        hear_all_but(99, 100);
        f.changes.check_silence(100);
        hear_all_but(dropped, 100 + kDisconnect);
        f.changes.check_silence(100 + kDisconnect);
        ASSERT_EQ(f.view.vote_of(2, dropped), Vote::Gone);
        f.changes.count_vote(other, dropped, Vote::Gone, 1);
        f.changes.settle_membership(100 + kDisconnect);
        f.agree({other}, 100 + kDisconnect);
        ASSERT_FALSE(f.view.running(dropped));
        EXPECT_EQ(f.slots[3].orphaned, dropped == 0);
        f.fake.shown = 10;  // now the joiner's input is needed
        const std::uint64_t t = 200 + kDisconnect;
        hear_all_but(dropped, t);
        f.changes.check_silence(t);
        if (dropped != 0) {
            EXPECT_NE(f.view.vote_of(2, 3), Vote::Gone) << "its maker lives: the handoff waits out disconnect_us";
            continue;
        }
        EXPECT_EQ(f.view.vote_of(2, 3), Vote::Gone) << "orphaned: voted gone at once";
        f.changes.count_vote(1, 3, Vote::Gone, 3);
        f.changes.settle_membership(t);
        f.agree({1}, t);
        const auto drops = f.fake.of(Kind::Disconnected);  // slot 3 learned absent, slot 0, slot 3
        ASSERT_EQ(drops.size(), 3u);
        EXPECT_EQ(drops[2].peer, 3u);
        EXPECT_EQ(drops[2].detail, "handoff orphaned: its owner left, agreed by 2 of 3 players");
        EXPECT_EQ(drops[2].reason, Reason::HandoffLapsed);
        EXPECT_EQ(f.slots[3].next_handoff_us, 0u) << "no backoff: the joiner was not at fault";
        EXPECT_EQ(f.slots[3].lapses, 0);
    }
}

// Issue 21: slot 1 is handed over (by us, the owner) and slot 2 dies before the joiner loads.
// The joiner's vetting needed slot 2's answer while the view named it running, so the time its
// handoff waited in that view says nothing of whether it can load: slot 2's drop starts its lapse
// clock over and withdraws our vote from the lapse. Before, in the same settle the two-player
// rule (slot 1's electorate now us and the joiner) dropped the joiner on that vote.
TEST(MembershipChanges, AnotherDropRestartsAPendingHandoffsClock) {
    Fixture f(3);
    f.handed_over_by_a_table(1, 10, 60);
    ASSERT_TRUE(f.view.joining(1));
    f.fake.shown = 10;
    f.hear_all_but(99, 100);
    f.changes.check_silence(100);
    const std::uint64_t dropped_us = 100 + kDisconnect;
    f.hear_all_but(2, dropped_us);
    f.changes.check_silence(dropped_us);  // slot 1 lapses, slot 2 timed out: the two-player rule drops it
    ASSERT_FALSE(f.view.running(2));
    EXPECT_TRUE(f.view.running(1)) << "not dropped on its lapse in the old view";
    EXPECT_NE(f.view.vote_of(0, 1), Vote::Gone);
    EXPECT_FALSE(f.slots[1].lapsed);
    EXPECT_FALSE(f.slots[1].orphaned) << "slot 2 did not make it";
    f.hear_all_but(2, dropped_us + 1);
    f.changes.check_silence(dropped_us + 1);
    f.hear_all_but(2, dropped_us + kDisconnect);
    f.changes.check_silence(dropped_us + kDisconnect);
    EXPECT_TRUE(f.view.running(1)) << "less than disconnect_us in the new view";
    f.hear_all_but(2, dropped_us + 1 + kDisconnect);
    f.changes.check_silence(dropped_us + 1 + kDisconnect);
    EXPECT_FALSE(f.view.running(1)) << "disconnect_us in the new view: it lapses";
    EXPECT_EQ(f.fake.of(Kind::Disconnected).back().reason, Reason::HandoffLapsedTwoPlayerRule);
}

// The joiner reached only the owner: we never welcomed its process, yet our stream of its slot
// is the owner's neutral input and we need it. Its handoff lapses here too (before, only a
// welcomed peer's was judged, and our vote was missing for good).
TEST(MembershipChanges, AHandoffLapsesAlsoWhenWeNeverWelcomedTheJoiner) {
    Fixture f(3);
    f.links[2].welcomed = false;
    const std::vector<std::uint8_t> zero{0};
    for (std::uint32_t fr = 0; fr < 10; ++fr) f.fake.queues[2].add_confirmed(fr, zero, true);
    f.fake.shown = 10;
    f.changes.check_silence(100);
    f.changes.check_silence(100 + kDisconnect);
    EXPECT_TRUE(f.slots[2].lapsed);
    EXPECT_EQ(f.view.vote_of(0, 2), Vote::Gone);
}

TEST(MembershipChanges, AKickIsOurVoteAndNamesItself) {
    Fixture f(3);
    f.changes.disconnect_player(2, 100);
    EXPECT_TRUE(f.slots[2].kick_vote);
    EXPECT_TRUE(f.view.running(2)) << "the other player must agree";
    f.changes.count_vote(1, 2, Vote::Gone, 1);
    f.changes.settle_membership(200);
    f.agree({1}, 200);
    EXPECT_EQ(f.fake.of(Kind::Disconnected).at(0).detail, "kicked, agreed by 2 of 3 players");
    EXPECT_EQ(f.fake.of(Kind::Disconnected).at(0).reason, Reason::KickVote);
    EXPECT_THROW(f.changes.disconnect_player(0, 300), std::invalid_argument) << "our own slot";
    EXPECT_THROW(f.changes.disconnect_player(3, 300), std::invalid_argument) << "not a slot";

    Fixture hosted(3, {0, 0, 2});
    EXPECT_THROW(hosted.changes.disconnect_player(1, 100), std::invalid_argument) << "our own guest";
    Fixture other(3, {0, 1, 1});
    EXPECT_THROW(other.changes.disconnect_player(2, 100), std::invalid_argument) << "a guest goes with its host";
}

// A restart claim (hellos from another process of a slot whose own has gone quiet) is noted at
// its first hello and is our vote once it has stood for restart_confirm_us, the old process
// unheard (rollback/restart_claim.h).
constexpr std::uint64_t kConfirm = restart_confirm_us(kInterrupt);

// A restart claim that has stood is our vote, not a drop: with three players a second voter must
// agree; hearing the old process again withdraws it, and silence that follows says "timed out",
// not "rejoining".
TEST(MembershipChanges, ARestartClaimIsOurVoteAndAMajorityDrops) {
    Fixture f(3);
    EXPECT_FALSE(f.changes.claim_restart(2, false, true, 100));
    EXPECT_EQ(f.view.vote_of(0, 2), Vote::None) << "the claim has not stood yet";
    EXPECT_FALSE(f.changes.claim_restart(2, false, true, 100 + kConfirm));
    EXPECT_EQ(f.view.vote_of(0, 2), Vote::Gone);
    EXPECT_TRUE(f.view.running(2)) << "one vote of three is no majority";
    EXPECT_TRUE(f.fake.of(Kind::Disconnected).empty());
    f.changes.count_vote(1, 2, Vote::Gone, 1);
    f.changes.settle_membership(200 + kConfirm);
    f.agree({1}, 200 + kConfirm);
    EXPECT_EQ(f.view.state(2), SlotState::Disconnected);
    EXPECT_EQ(f.fake.of(Kind::Disconnected).at(0).detail, "rejoining, agreed by 2 of 3 players");
    EXPECT_EQ(f.fake.of(Kind::Disconnected).at(0).reason, Reason::Rejoining);
    EXPECT_FALSE(f.slots[2].restart_claim.stands(0)) << "the drop's new epoch forgets the claim";

    Fixture heard(3);
    heard.hear_all_but(99, 0);
    EXPECT_FALSE(heard.changes.claim_restart(2, true, true, 100));
    EXPECT_FALSE(heard.changes.claim_restart(2, true, true, 100 + kConfirm));
    EXPECT_EQ(heard.view.vote_of(0, 2), Vote::Gone);
    heard.view.vote_local(2, false);  // its old process spoke again (the session withdraws the vote)
    heard.hear_all_but(2, kDisconnect);
    heard.changes.check_silence(kDisconnect);
    heard.changes.count_vote(1, 2, Vote::Gone, 1);
    heard.changes.settle_membership(kDisconnect + 1);
    heard.agree({1}, kDisconnect + 1);
    EXPECT_EQ(heard.fake.of(Kind::Disconnected).at(0).detail, "timed out, agreed by 2 of 3 players");
    EXPECT_EQ(heard.fake.of(Kind::Disconnected).at(0).reason, Reason::TimedOut);
}

TEST(MembershipChanges, TwoPlayersARestartClaimDecidesUnderPlayOnAloneOnly) {
    Fixture alone(2);
    EXPECT_FALSE(alone.changes.claim_restart(1, true, true, 100));
    EXPECT_TRUE(alone.view.running(1));
    EXPECT_TRUE(alone.changes.claim_restart(1, true, true, 100 + kConfirm));
    EXPECT_EQ(alone.view.state(1), SlotState::Disconnected);
    EXPECT_EQ(alone.fake.of(Kind::Disconnected).at(0).detail, "restarted, by 1 of 2 votes (the two-player rule, play_on_alone: this process plays on alone)");
    EXPECT_EQ(alone.fake.of(Kind::Disconnected).at(0).reason, Reason::RestartedTwoPlayerRule);

    Fixture never(2, {}, TwoPlayerRule::NoDrop);
    EXPECT_FALSE(never.changes.claim_restart(1, false, true, 100));
    EXPECT_FALSE(never.changes.claim_restart(1, false, true, 100 + kConfirm));
    EXPECT_TRUE(never.view.running(1));
}

// Issue 21: an outsider's claim lands while slot 1's process is silent for a genuine loss
// burst. With two players our vote is the decision, so the claim must not be the vote before
// it has stood the window: the old process heard again in it voids the claim, and the next
// hello starts the window over (it used to count at once: slot 1 dropped).
TEST(MembershipChanges, TwoPlayersAClaimTheOldProcessAnswersIsNoVote) {
    Fixture f(2);
    f.hear_all_but(99, 1'000'000);
    EXPECT_FALSE(f.changes.claim_restart(1, false, true, 1'400'000));
    f.hear_all_but(99, 1'400'000 + kConfirm / 2);  // the burst ends: slot 1 speaks
    EXPECT_FALSE(f.changes.claim_restart(1, false, true, 1'400'000 + kConfirm)) << "the claim was answered";
    EXPECT_TRUE(f.view.running(1));
    EXPECT_EQ(f.view.vote_of(0, 1), Vote::None);
    EXPECT_TRUE(f.fake.of(Kind::Disconnected).empty());
    // The claim made again, unanswered this time, counts a window later.
    EXPECT_FALSE(f.changes.claim_restart(1, false, true, 1'400'000 + 2 * kConfirm - 1));
    EXPECT_TRUE(f.changes.claim_restart(1, false, true, 1'400'000 + 2 * kConfirm));
    EXPECT_EQ(f.fake.of(Kind::Disconnected).at(0).reason, Reason::RejoiningTwoPlayerRule);
}

// A doubted claim (admit_hello: the old process was heard lately) starts the window but is never
// the vote by itself: a genuine restart quicker than restart_quiet_us is voted gone a window
// after its first hello, once its predecessor is also quiet.
TEST(MembershipChanges, ADoubtedClaimStartsTheWindowButNeverVotes) {
    Fixture f(2);
    f.hear_all_but(99, 1'000'000);
    EXPECT_FALSE(f.changes.claim_restart(1, true, false, 1'050'000));
    EXPECT_FALSE(f.changes.claim_restart(1, true, false, 1'050'000 + kConfirm)) << "still doubted";
    EXPECT_TRUE(f.view.running(1));
    EXPECT_TRUE(f.changes.claim_restart(1, true, true, 1'050'000 + kConfirm + 1));
    EXPECT_EQ(f.fake.of(Kind::Disconnected).at(0).reason, Reason::RestartedTwoPlayerRule);
}

TEST(MembershipChanges, PartitionedOncePerEpisode) {
    Fixture f(3);
    f.view.vote_local(1, true);
    f.view.vote_local(2, true);  // we hear nobody: one of three
    f.changes.settle_membership(100);
    EXPECT_TRUE(f.changes.partitioned());
    for (PlayerId s = 0; s < 3; ++s) EXPECT_TRUE(f.view.running(s)) << "a minority drops nobody";
    ASSERT_EQ(f.fake.of(Kind::Partitioned).size(), 1u);
    EXPECT_EQ(f.fake.of(Kind::Partitioned)[0].frame, f.fake.confirmed);
    EXPECT_EQ(f.fake.of(Kind::Partitioned)[0].detail, "hears 1 of 3 players: no majority, nobody is dropped");
    EXPECT_EQ(f.fake.of(Kind::Partitioned)[0].reason, Reason::NoMajority);
    f.changes.settle_membership(200);
    EXPECT_EQ(f.fake.of(Kind::Partitioned).size(), 1u) << "once per episode";

    f.view.vote_local(1, false);  // heard again: two of three
    f.changes.settle_membership(300);
    EXPECT_FALSE(f.changes.partitioned());
    f.view.vote_local(1, true);
    f.changes.settle_membership(400);
    EXPECT_EQ(f.fake.of(Kind::Partitioned).size(), 2u) << "a new episode";
}

TEST(MembershipChanges, APeersTableHandsASlotOverOrTellsADropWeMissed) {
    Fixture f(3);
    f.changes.adopt_slot(2, {2, SlotState::Disconnected, 1, 0}, 100);
    EXPECT_EQ(f.view.state(2), SlotState::Disconnected);
    ASSERT_EQ(f.fake.of(Kind::Disconnected).size(), 1u);
    EXPECT_EQ(f.fake.of(Kind::Disconnected)[0].detail, "learned from a peer");
    EXPECT_EQ(f.fake.of(Kind::Disconnected)[0].reason, Reason::LearnedFromPeer);
    EXPECT_EQ(f.fake.failed_peers, std::vector<PlayerId>{2});

    // The owner handed it to a new process: listen to it from now on, its predecessor forgotten.
    for (int i = 0; i < 10; ++i) f.links[2].note_malformed("garbage");
    ASSERT_TRUE(f.links[2].error());
    f.fake.queues[2].add_confirmed(0, std::vector<std::uint8_t>{1});
    f.changes.adopt_slot(2, {2, SlotState::Running, 2, 0}, 200);
    EXPECT_TRUE(f.view.running(2));
    EXPECT_EQ(f.view.epoch(2), 2);
    const auto joined = f.fake.of(Kind::Joined);
    ASSERT_EQ(joined.size(), 1u);
    EXPECT_EQ(joined[0].frame, 1u) << "its stream's count";
    EXPECT_EQ(joined[0].reason, Reason::LearnedFromPeer);
    EXPECT_FALSE(f.links[2].error());
    EXPECT_TRUE(f.links[2].heard);
    EXPECT_EQ(f.fake.replaced_peers, std::vector<PlayerId>{2});
    EXPECT_EQ(f.fake.changed_hands, (std::vector<PlayerId>{2, 2}));
    EXPECT_FALSE(f.fake.failed);
}

// Issue 21, "membership that cannot freeze": a peer's table hands slot 1 to a joiner, then slot 2
// goes silent before the joiner plays. The joiner is no voter until its own stream starts here,
// so this survivor's view is two voters and its vote drops the dead slot by the two-player rule
// (before, 1 of 3 votes: partitioned, for good); once the joiner's stream starts it votes.
TEST(MembershipChanges, AJoinerHandedOverIsNoVoterUntilItsStreamStarts) {
    Fixture f(3);
    const std::vector<std::uint8_t> zero{0};
    f.handed_over_by_a_table(1, 12, 100);
    EXPECT_TRUE(f.view.joining(1));
    EXPECT_EQ(f.view.running_voters(), 2);
    f.hear_all_but(99, 100);
    f.changes.check_silence(100);
    f.hear_all_but(2, 100 + kDisconnect + 1);
    f.changes.check_silence(100 + kDisconnect + 1);
    EXPECT_TRUE(f.fake.of(Kind::Partitioned).empty());
    ASSERT_EQ(f.fake.of(Kind::Disconnected).size(), 2u);
    EXPECT_EQ(f.fake.of(Kind::Disconnected)[1].peer, 2u);
    EXPECT_EQ(f.fake.of(Kind::Disconnected)[1].reason, Reason::TimedOutTwoPlayerRule);
    EXPECT_TRUE(f.view.running(1)) << "the joiner stays";
    EXPECT_TRUE(f.view.joining(1));
    f.fake.queues[1].add_confirmed(12, zero);  // its own first input
    f.changes.check_silence(200 + kDisconnect);
    EXPECT_FALSE(f.view.joining(1));
    EXPECT_EQ(f.view.running_voters(), 2);
}

TEST(MembershipChanges, APeersTableThatDropsOurOwnSlotKicksUs) {
    Fixture f(3);
    f.changes.adopt_slot(0, {0, SlotState::Disconnected, 1, 0}, 100);
    ASSERT_EQ(f.fake.of(Kind::Kicked).size(), 1u);
    EXPECT_EQ(f.fake.of(Kind::Kicked)[0].detail, "the other peers dropped this slot");
    EXPECT_EQ(f.fake.of(Kind::Kicked)[0].reason, Reason::LearnedFromPeer);
    EXPECT_TRUE(f.fake.failed);
}

}  // namespace
}  // namespace lockroll::rollback

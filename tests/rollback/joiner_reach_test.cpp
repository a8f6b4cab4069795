// JoinerReach (rollback/joiner_reach.h) on its own: a joiner that has not loaded is cut off once
// the other voters it reaches are no majority of the view -- a voter unheard for disconnect_us,
// or named silent by a vetting -- and no longer once they are heard.
#include "rollback/joiner_reach.h"

#include <gtest/gtest.h>

#include <initializer_list>
#include <vector>

namespace lockroll::rollback {
namespace {

constexpr std::uint64_t kSecond = 1'000'000;

SessionConfig joiner(int players, PlayerId slot) {
    SessionConfig c;
    c.players = players;
    c.local_player = slot;
    c.role = Role::Joiner;
    c.disconnect_us = 5 * kSecond;
    return c;
}

// Begun at 0, and every slot of `heard` heard just after.
JoinerReach hearing(std::initializer_list<PlayerId> heard) {
    JoinerReach r;
    r.begin(0);
    for (PlayerId p : heard) r.heard(p, 100);
    return r;
}

TEST(JoinerReach, NothingBeforeBegin) {
    const JoinerReach r;
    EXPECT_FALSE(r.judge(joiner(3, 2), 60 * kSecond).cut_off);
}

TEST(JoinerReach, UnheardVotersCountOnlyAfterTheDisconnectTimeout) {
    const SessionConfig c = joiner(3, 2);
    JoinerReach r;
    r.begin(kSecond);
    r.heard(0, kSecond + 100);
    EXPECT_FALSE(r.judge(c, 5 * kSecond).cut_off) << "slot 1 may still answer";
    const auto v = r.judge(c, 6 * kSecond);
    EXPECT_TRUE(v.cut_off);
    EXPECT_EQ(v.reached, 1);
    EXPECT_EQ(v.others, 2);
    EXPECT_EQ(v.needed, 2);
    EXPECT_EQ(v.unreached, std::vector<PlayerId>{1});
    // Heard at last: a majority of others again.
    r.heard(1, 7 * kSecond);
    EXPECT_FALSE(r.judge(c, 7 * kSecond).cut_off);
}

TEST(JoinerReach, HearingNobodyIsCutOff) {
    const JoinerReach r = hearing({});
    const auto v = r.judge(joiner(3, 2), 5 * kSecond);
    EXPECT_TRUE(v.cut_off);
    EXPECT_EQ(v.reached, 0);
    EXPECT_EQ(v.unreached, (std::vector<PlayerId>{0, 1}));
}

TEST(JoinerReach, AVoterNamedSilentByAVettingIsUnreachedUntilHeard) {
    const SessionConfig c = joiner(3, 2);
    JoinerReach r = hearing({0, 1});
    EXPECT_FALSE(r.judge(c, 10 * kSecond).cut_off);
    const std::vector<PlayerId> silent{1};
    r.named_silent(silent);
    EXPECT_TRUE(r.judge(c, 10 * kSecond).cut_off) << "before the timeout too: it was asked and did not answer";
    r.heard(1, 11 * kSecond);
    EXPECT_FALSE(r.judge(c, 11 * kSecond).cut_off);
}

// The offer's table is the view: a slot it says was dropped is no voter.
TEST(JoinerReach, TheOffersTableIsTheView) {
    const SessionConfig c = joiner(4, 2);
    JoinerReach r = hearing({0, 1});
    EXPECT_TRUE(r.judge(c, 6 * kSecond).cut_off) << "the starting view of four: 2 of 3 others is no majority of 4";
    const std::vector<SlotEntry> table{{0, SlotState::Running, 0, 0},
                                       {1, SlotState::Running, 0, 0},
                                       {2, SlotState::Running, 2, 0},
                                       {3, SlotState::Disconnected, 1, 0}};
    r.saw_view(table);
    const auto v = r.judge(c, 6 * kSecond);
    EXPECT_FALSE(v.cut_off);
    EXPECT_EQ(v.others, 2);
    EXPECT_EQ(v.needed, 2);
}

// A provider cannot shrink the view: a slot heard from runs whatever its table says.
TEST(JoinerReach, ASlotHeardFromRunsWhateverTheTableSays) {
    const SessionConfig c = joiner(3, 2);
    JoinerReach r = hearing({0, 1});
    r.named_silent(std::vector<PlayerId>{1});
    const std::vector<SlotEntry> table{{0, SlotState::Running, 0, 0},
                                       {1, SlotState::Disconnected, 1, 0},
                                       {2, SlotState::Running, 2, 0}};
    r.saw_view(table);
    const auto v = r.judge(c, kSecond);
    EXPECT_EQ(v.others, 2);
    EXPECT_TRUE(v.cut_off);
}

// A view of two: the two-player rule, as for the vetting. PlayOnAlone: the other's word is
// enough, so only its silence cuts the joiner off; NoDrop: no majority of others exists, and
// the joiner is told so only once the other is silent (never while it hears it).
TEST(JoinerReach, AViewOfTwoFollowsTheTwoPlayerRule) {
    SessionConfig c = joiner(2, 1);
    JoinerReach r;
    r.begin(0);
    EXPECT_TRUE(r.judge(c, 5 * kSecond).cut_off);
    r.heard(0, 5 * kSecond);
    EXPECT_FALSE(r.judge(c, 5 * kSecond).cut_off);
    EXPECT_EQ(r.judge(c, 5 * kSecond).needed, 1);
    c.two_player_rule = TwoPlayerRule::NoDrop;
    EXPECT_FALSE(r.judge(c, 5 * kSecond).cut_off);
    EXPECT_EQ(r.judge(c, 5 * kSecond).needed, 2);
}

// Absent slots are no voters; a late joiner into one counts its own slot as running.
TEST(JoinerReach, AbsentSlotsAreNoVoters) {
    SessionConfig c = joiner(4, 3);
    c.absent_slots = 0b1100;  // slots 2 and 3 absent from frame 0
    JoinerReach r = hearing({0});
    const auto v = r.judge(c, 6 * kSecond);
    EXPECT_EQ(v.others, 2);
    EXPECT_EQ(v.needed, 2);
    EXPECT_TRUE(v.cut_off);
    r.heard(1, 7 * kSecond);
    EXPECT_FALSE(r.judge(c, 7 * kSecond).cut_off);
}

// A process that plays several slots is one voter: its guests are not counted.
TEST(JoinerReach, AHostOfGuestsIsOneVoter) {
    SessionConfig c = joiner(4, 3);
    c.slot_hosts = {0, 0, 2, 3};  // slot 0's process plays slot 1 too
    JoinerReach r = hearing({0});
    const auto v = r.judge(c, 6 * kSecond);
    EXPECT_EQ(v.others, 2);  // processes 0 and 2
    EXPECT_TRUE(v.cut_off);
    r.heard(2, 7 * kSecond);
    EXPECT_FALSE(r.judge(c, 7 * kSecond).cut_off);
}

// Issue 21: a player is judged only once told it restarted (its silence counted from begin());
// a joiner always; a spectator never.
TEST(JoinerReach, APlayerIsJudgedOnlyOnceToldItRestarted) {
    SessionConfig c = joiner(3, 2);
    c.role = Role::Player;
    JoinerReach r = hearing({0});
    EXPECT_TRUE(r.judges(Role::Joiner));
    EXPECT_FALSE(r.judges(Role::Player)) << "a first start cannot be told from a restart";
    EXPECT_FALSE(r.judges(Role::Spectator));
    r.told_restarted();
    EXPECT_TRUE(r.judges(Role::Player));
    EXPECT_FALSE(r.judges(Role::Spectator));
    EXPECT_FALSE(r.judge(c, 4 * kSecond).cut_off);
    EXPECT_TRUE(r.judge(c, 6 * kSecond).cut_off) << "slot 1 unheard since begin() for disconnect_us";
}

// disconnect_us = 0 (never time out): only a vetting's naming counts.
TEST(JoinerReach, WithoutADisconnectTimeoutOnlyNamedSilenceCounts) {
    SessionConfig c = joiner(3, 2);
    c.disconnect_us = 0;
    JoinerReach r;
    r.begin(0);
    EXPECT_FALSE(r.judge(c, 3600 * kSecond).cut_off);
    r.named_silent(std::vector<PlayerId>{0, 1});
    EXPECT_TRUE(r.judge(c, 3600 * kSecond).cut_off);
}

}  // namespace
}  // namespace lockroll::rollback

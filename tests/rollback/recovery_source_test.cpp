// recovery_source (rollback/recovery_source.h) on its own: the majority's state is reloaded by
// the odd ones, a tie keeps the lowest (or highest) slot's group.
#include "rollback/recovery_source.h"

#include <gtest/gtest.h>

#include <optional>
#include <vector>

namespace lockroll::rollback {
namespace {

using Answers = std::vector<std::pair<PlayerId, std::uint64_t>>;

TEST(RecoverySource, TheMinorityReloadsFromTheMajoritysLowestSlot) {
    const Answers others{{0, 7}, {2, 7}, {3, 7}};
    EXPECT_EQ(recovery_source(1, 9, others, DesyncKeep::LowestSlot), PlayerId{0});
    const Answers with_odd{{1, 9}, {2, 7}, {3, 7}};
    EXPECT_EQ(recovery_source(0, 7, with_odd, DesyncKeep::LowestSlot), std::nullopt) << "in the majority: stays";
}

TEST(RecoverySource, ATieKeepsTheGroupOfTheLowestOrHighestSlot) {
    const Answers other{{1, 5}};
    EXPECT_EQ(recovery_source(0, 4, other, DesyncKeep::LowestSlot), std::nullopt);
    EXPECT_EQ(recovery_source(0, 4, other, DesyncKeep::HighestSlot), PlayerId{1});
    const Answers lower{{0, 4}};
    EXPECT_EQ(recovery_source(1, 5, lower, DesyncKeep::LowestSlot), PlayerId{0});
    EXPECT_EQ(recovery_source(1, 5, lower, DesyncKeep::HighestSlot), std::nullopt);
}

TEST(RecoverySource, OnlyTheLow32BitsCount) {
    const Answers other{{1, 0x1'0000'0005}, {2, 0x2'0000'0005}};
    EXPECT_EQ(recovery_source(0, 5, other, DesyncKeep::LowestSlot), std::nullopt) << "all three agree";
}

using Told = std::vector<std::pair<PlayerId, std::optional<std::uint64_t>>>;
using Act = RecoveryStep::Act;

// Slot 1 saw checksum 9 where slots 0 and 2 confirmed 7, at 10 s; one recovery allowed.
RecoveryCase minority(const Told& peers, std::uint64_t now_us) {
    RecoveryCase c;
    c.me = 1;
    c.mine = 9;
    c.peers = peers;
    c.mismatch_since_us = 10'000'000;
    c.now_us = now_us;
    c.max_recoveries = 1;
    return c;
}

TEST(RecoveryStep, TheMinorityReloadsFromTheMajority) {
    const Told told{{0, 7}, {2, 7}};
    const RecoveryStep s = next_recovery_step(minority(told, 10'000'000));
    EXPECT_EQ(s.act, Act::Reload);
    EXPECT_EQ(s.from, PlayerId{0});
    RecoveryCase in_majority = minority(told, 10'000'000);
    in_majority.mine = 7;
    EXPECT_EQ(next_recovery_step(in_majority).act, Act::Forget) << "the odd ones reload, not us";
}

TEST(RecoveryStep, WaitsWhileNarrowingForAtMostThreeSeconds) {
    const Told told{{0, 7}, {2, 7}};
    RecoveryCase c = minority(told, 12'999'999);
    c.investigating = true;
    EXPECT_EQ(next_recovery_step(c).act, Act::Wait);
    c.now_us = 13'000'000;
    EXPECT_EQ(next_recovery_step(c).act, Act::Reload);
}

TEST(RecoveryStep, WaitsForEveryLivePlayersWordForAtMostFiveSeconds) {
    const Told told{{0, 7}, {2, std::nullopt}, {3, 7}};
    EXPECT_EQ(next_recovery_step(minority(told, 14'999'999)).act, Act::Wait);
    const RecoveryStep s = next_recovery_step(minority(told, 15'000'000));  // slot 2 left out
    EXPECT_EQ(s.act, Act::Reload);
    EXPECT_EQ(s.from, PlayerId{0});
}

TEST(RecoveryStep, ForgetsAMismatchWhoseFrameItNoLongerHolds) {
    const Told told{{0, 7}, {2, 7}};
    RecoveryCase c = minority(told, 10'000'000);
    c.mine.reset();
    EXPECT_EQ(next_recovery_step(c).act, Act::Forget);
}

TEST(RecoveryStep, GivesUpBeyondTheRecoveryLimit) {
    const Told told{{0, 7}, {2, 7}};
    RecoveryCase c = minority(told, 10'000'000);
    c.recoveries = 1;
    EXPECT_EQ(next_recovery_step(c).act, Act::GiveUp);
}

// Issue 21 (Q7): with two players a disagreement has no majority; the events must say the tie
// rule decided, not a majority.
TEST(RecoverySource, TheChoiceNamesTheRuleThatKeptTheGroup) {
    const Answers other{{1, 5}};
    const RecoveryChoice tie = choose_recovery(1, 4, Answers{{0, 5}}, DesyncKeep::LowestSlot);
    EXPECT_EQ(tie.source, PlayerId{0});
    EXPECT_EQ(tie.rule, "no majority (a tie, 1 against 1): the tie rule (two_player_keep: lowest_slot) keeps slot 0's group");
    const RecoveryChoice high = choose_recovery(0, 4, other, DesyncKeep::HighestSlot);
    EXPECT_EQ(high.source, PlayerId{1});
    EXPECT_EQ(high.rule, "no majority (a tie, 1 against 1): the tie rule (two_player_keep: highest_slot) keeps slot 1's group");
    const RecoveryChoice most = choose_recovery(1, 9, Answers{{0, 7}, {2, 7}, {3, 7}}, DesyncKeep::LowestSlot);
    EXPECT_EQ(most.source, PlayerId{0});
    EXPECT_EQ(most.rule, "the biggest group, 3 of 4");
    const RecoveryChoice split = choose_recovery(0, 7, Answers{{1, 7}, {2, 9}, {3, 9}}, DesyncKeep::LowestSlot);
    EXPECT_EQ(split.source, std::nullopt) << "a 2/2 tie keeps slot 0's group";
    EXPECT_EQ(split.rule, "no majority (a tie, 2 against 2): the tie rule (two_player_keep: lowest_slot) keeps slot 0's group");
    // The session's step carries it to the recovery's event.
    const Told told{{0, 7}, {2, 7}};
    const RecoveryStep step = next_recovery_step(minority(told, 10'000'000));
    EXPECT_FALSE(step.tie);
    EXPECT_EQ(step.rule, "the biggest group, 2 of 3");
}

}  // namespace
}  // namespace lockroll::rollback

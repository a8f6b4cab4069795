// arbitrate (rollback/arbitration.h) on its own: the one checksum rule of the P2P recovery and
// the relay server's rooms. Links only lockroll_relay_protocol, as the server does: no sim/.
#include "rollback/arbitration.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>

namespace lockroll::rollback {
namespace {

constexpr std::uint64_t bit(int v) { return std::uint64_t{1} << v; }

const ArbitrationRule kLowest{ArbitrationTie::LowestSlot, false};
const ArbitrationRule kHighest{ArbitrationTie::HighestSlot, false};
const ArbitrationRule kEndMatch{ArbitrationTie::LowestSlot, true};

TEST(Arbitration, AStrictMajorityWinsAndEveryOtherVoterIsTheMinority) {
    const std::array<std::uint64_t, 4> values{7, 9, 7, 7};
    const auto v = arbitrate(values, 0b1111, 4, kLowest);
    EXPECT_EQ(v.voters, 4);
    EXPECT_EQ(v.value, 7u);
    EXPECT_EQ(v.winners, bit(0) | bit(2) | bit(3));
    EXPECT_EQ(v.minority, bit(1));
    EXPECT_TRUE(v.strict_majority);
    EXPECT_FALSE(v.tie_broken);
    EXPECT_FALSE(v.no_majority);
    EXPECT_EQ(v.lowest_winner(), 0);
    // The same ballot under the other tie rule: a majority needs no tie rule.
    EXPECT_EQ(arbitrate(values, 0b1111, 4, kHighest).winners, v.winners);
}

TEST(Arbitration, OnlyVotersCount) {
    // Slot 1 holds a stale value but did not vote: 0 and 2 agree, 3 is the minority.
    const std::array<std::uint64_t, 4> values{7, 9, 7, 8};
    const auto v = arbitrate(values, bit(0) | bit(2) | bit(3), 4, kLowest);
    EXPECT_EQ(v.voters, 3);
    EXPECT_EQ(v.winners, bit(0) | bit(2));
    EXPECT_EQ(v.minority, bit(3));
    EXPECT_TRUE(v.strict_majority);
    // Voters past the values given are ignored, and no voter at all is an empty verdict.
    EXPECT_EQ(arbitrate(std::span(values).first(2), 0b1111, 4, kLowest).voters, 2);
    const auto none = arbitrate(values, 0, 4, kLowest);
    EXPECT_EQ(none.voters, 0);
    EXPECT_EQ(none.winners | none.minority, 0u);
    EXPECT_EQ(none.lowest_winner(), -1);
}

TEST(Arbitration, TheBiggestGroupWinsWithoutAStrictMajority) {
    const std::array<std::uint64_t, 4> values{1, 2, 2, 3};
    const auto v = arbitrate(values, 0b1111, 4, kLowest);
    EXPECT_EQ(v.value, 2u);
    EXPECT_EQ(v.winners, bit(1) | bit(2));
    EXPECT_EQ(v.minority, bit(0) | bit(3));
    EXPECT_FALSE(v.strict_majority) << "2 of 4 is no strict majority";
    EXPECT_FALSE(v.tie_broken) << "no other group is as big";
}

TEST(Arbitration, EqualGroupsKeepTheOneWhoseLowestVoterIsLowestOrHighest) {
    // 2 / 2 / 1: groups {0, 3}, {1, 2} and {4}.
    const std::array<std::uint64_t, 5> values{5, 6, 6, 5, 9};
    const auto low = arbitrate(values, 0b11111, 5, kLowest);
    EXPECT_EQ(low.winners, bit(0) | bit(3));
    EXPECT_EQ(low.minority, bit(1) | bit(2) | bit(4));
    EXPECT_TRUE(low.tie_broken);
    EXPECT_FALSE(low.strict_majority);
    const auto high = arbitrate(values, 0b11111, 5, kHighest);
    EXPECT_EQ(high.winners, bit(1) | bit(2)) << "the group whose lowest voter (1) is the highest";
    EXPECT_EQ(high.minority, bit(0) | bit(3) | bit(4));
    EXPECT_TRUE(high.tie_broken);
}

TEST(Arbitration, TwoVotersWhoDisagreeKeepOneOfThemByTheTieRule) {
    const std::array<std::uint64_t, 2> values{4, 5};
    const auto low = arbitrate(values, 0b11, 2, kLowest);
    EXPECT_EQ(low.winners, bit(0));
    EXPECT_EQ(low.minority, bit(1));
    EXPECT_TRUE(low.tie_broken);
    EXPECT_FALSE(low.strict_majority);
    EXPECT_FALSE(low.no_majority);
    const auto high = arbitrate(values, 0b11, 2, kHighest);
    EXPECT_EQ(high.winners, bit(1));
    EXPECT_EQ(high.minority, bit(0));
}

TEST(Arbitration, TwoVotersAloneWhoDisagreeHaveNoMajorityUnderEndMatch) {
    const std::array<std::uint64_t, 2> values{4, 5};
    const auto v = arbitrate(values, 0b11, 2, kEndMatch);
    EXPECT_TRUE(v.no_majority);
    EXPECT_EQ(v.winners, 0u);
    EXPECT_EQ(v.minority, 0b11u) << "both are told";
    EXPECT_EQ(v.lowest_winner(), -1);
    // Not alone (a third running voter did not report in time): the tie rule keeps the lowest.
    const std::array<std::uint64_t, 3> three{4, 5, 0};
    const auto not_alone = arbitrate(three, 0b011, 3, kEndMatch);
    EXPECT_FALSE(not_alone.no_majority);
    EXPECT_EQ(not_alone.winners, bit(0));
    EXPECT_EQ(not_alone.minority, bit(1));
    // Two alone who agree: a strict majority, nobody in the minority.
    const std::array<std::uint64_t, 2> same{4, 4};
    const auto agree = arbitrate(same, 0b11, 2, kEndMatch);
    EXPECT_FALSE(agree.no_majority);
    EXPECT_TRUE(agree.strict_majority);
    EXPECT_EQ(agree.minority, 0u);
}

TEST(Arbitration, ValuesAreComparedWholeAndSlotsReach63) {
    // A caller that has only the low 32 bits (P2P) masks them; arbitrate never does.
    std::array<std::uint64_t, 64> values{};
    values[0] = 0x1'0000'0005;
    values[40] = 0x2'0000'0005;
    values[63] = 0x2'0000'0005;
    const auto v = arbitrate(values, bit(0) | bit(40) | bit(63), 3, kLowest);
    EXPECT_EQ(v.winners, bit(40) | bit(63));
    EXPECT_EQ(v.minority, bit(0));
    EXPECT_EQ(v.lowest_winner(), 40);
    EXPECT_TRUE(v.is_winner(63));
    EXPECT_TRUE(v.is_minority(0));
    EXPECT_FALSE(v.is_winner(64));
}

}  // namespace
}  // namespace lockroll::rollback

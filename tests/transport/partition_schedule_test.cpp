// PartitionSchedule on its own: which links a cut separates, when, and what it refuses.
#include "transport/partition_schedule.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

namespace lockroll::transport {
namespace {

PartitionCut cut(std::vector<std::vector<PeerId>> sets, Micros from, Micros until) {
    return PartitionCut{std::move(sets), from, until};
}

TEST(PartitionSchedule, EmptyCutsNothing) {
    const PartitionSchedule s;
    EXPECT_TRUE(s.empty());
    for (PeerId a = 0; a < 4; ++a)
        for (PeerId b = 0; b < 4; ++b) EXPECT_FALSE(s.is_cut(a, b, 1'000));
}

// Every pair of 6 slots at times before, at the edges of, inside and after the window: cut
// exactly when the two are on different sides and from <= now < until. Slot 5 is in no set.
TEST(PartitionSchedule, CutsExactlyTheLinksBetweenSetsInsideTheWindow) {
    PartitionSchedule s;
    s.add(cut({{0, 1}, {2, 3, 4}}, 1'000, 2'000));
    const int side[6] = {0, 0, 1, 1, 1, -1};
    for (const Micros now : {Micros{0}, Micros{999}, Micros{1'000}, Micros{1'500}, Micros{1'999}, Micros{2'000},
                             Micros{5'000}}) {
        const bool active = now >= 1'000 && now < 2'000;
        for (PeerId a = 0; a < 6; ++a)
            for (PeerId b = 0; b < 6; ++b) {
                const bool across = side[a] >= 0 && side[b] >= 0 && side[a] != side[b];
                EXPECT_EQ(s.is_cut(a, b, now), active && across) << a << "->" << b << " at " << now;
            }
    }
}

TEST(PartitionSchedule, ASlotNamedInNoSetKeepsAllItsLinks) {
    PartitionSchedule s;
    s.add(cut({{0}, {1}}, 0, 100));
    EXPECT_TRUE(s.is_cut(0, 1, 50));
    EXPECT_TRUE(s.is_cut(1, 0, 50));
    for (PeerId other : {0u, 1u}) {
        EXPECT_FALSE(s.is_cut(2, other, 50));
        EXPECT_FALSE(s.is_cut(other, 2, 50));
    }
}

TEST(PartitionSchedule, ThreeSetsCutEveryPairOfSides) {
    PartitionSchedule s;
    s.add(cut({{0}, {1}, {2, 3}}, 10, 20));
    EXPECT_TRUE(s.is_cut(0, 1, 10));
    EXPECT_TRUE(s.is_cut(1, 2, 10));
    EXPECT_TRUE(s.is_cut(3, 0, 10));
    EXPECT_FALSE(s.is_cut(2, 3, 10));
}

TEST(PartitionSchedule, SeveralCutsCombineAndMayOverlapInTime) {
    PartitionSchedule s;
    s.add(cut({{0}, {1}}, 100, 300));
    s.add(cut({{1}, {2}}, 200, 400));
    EXPECT_TRUE(s.is_cut(0, 1, 150));
    EXPECT_FALSE(s.is_cut(1, 2, 150));
    EXPECT_TRUE(s.is_cut(0, 1, 250));
    EXPECT_TRUE(s.is_cut(1, 2, 250));
    EXPECT_FALSE(s.is_cut(0, 2, 250));  // neither cut names both
    EXPECT_FALSE(s.is_cut(0, 1, 350));
    EXPECT_TRUE(s.is_cut(2, 1, 350));
    EXPECT_EQ(s.cuts().size(), 2u);
}

TEST(PartitionSchedule, ShiftedMovesEveryWindow) {
    PartitionSchedule s;
    s.add(cut({{0}, {1}}, 100, 300));
    const PartitionSchedule later = s.shifted(4'000'000);
    EXPECT_FALSE(later.is_cut(0, 1, 100));
    EXPECT_TRUE(later.is_cut(0, 1, 4'000'100));
    EXPECT_FALSE(later.is_cut(0, 1, 4'000'300));
    EXPECT_EQ(later.cuts()[0].sets, s.cuts()[0].sets);
    EXPECT_EQ(s.shifted(0), s);
}

TEST(PartitionSchedule, RefusesBadCutsNamingWhatIsWrong) {
    const std::pair<PartitionCut, const char*> bad[] = {
        {cut({{0, 1}}, 0, 10), "at least two sets"},
        {cut({{0}, {}}, 0, 10), "set 2 is empty"},
        {cut({{0, 1}, {1, 2}}, 0, 10), "slot 1 is named twice"},
        {cut({{0, 0}, {1}}, 0, 10), "slot 0 is named twice"},
        {cut({{0}, {1}}, 10, 10), "start before it ends"},
        {cut({{0}, {1}}, 11, 10), "start before it ends"},
    };
    for (const auto& [c, want] : bad) {
        EXPECT_NE(validate(c).find(want), std::string::npos) << validate(c);
        PartitionSchedule s;
        EXPECT_THROW(s.add(c), std::invalid_argument) << want;
        EXPECT_TRUE(s.empty());
    }
    EXPECT_EQ(validate(cut({{0}, {1}}, 0, 1)), "");
}

TEST(PartitionSchedule, CheckSlotsNamesTheFirstSlotOutOfRange) {
    PartitionSchedule s;
    s.add(cut({{0, 1}, {2, 7}}, 0, 10));
    EXPECT_EQ(s.check_slots(8), "");
    EXPECT_EQ(s.check_slots(4), "slot 7 is not in 0..3");
}

}  // namespace
}  // namespace lockroll::transport

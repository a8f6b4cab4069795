// sim/group_by_label.h: the stable counting sort that groups a step's links by island and by
// colour. Checked against std::stable_sort on random labels, and on its edge cases.
#include "sim/group_by_label.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <vector>

namespace lockroll::sim {
namespace {

template <class Label>
void expect_grouped_as_stable_sort(const std::vector<Label>& labels, std::size_t groups) {
    std::vector<std::uint32_t> start(groups + 1, 0);
    for (Label l : labels) ++start[static_cast<std::size_t>(l) + 1];
    std::vector<std::uint32_t> order;
    group_by_label<Label>(labels, start, order);

    std::vector<std::uint32_t> expected(labels.size());
    for (std::size_t k = 0; k < labels.size(); ++k) expected[k] = static_cast<std::uint32_t>(k);
    std::stable_sort(expected.begin(), expected.end(),
                     [&](std::uint32_t x, std::uint32_t y) { return labels[x] < labels[y]; });
    ASSERT_EQ(order, expected);

    ASSERT_EQ(start.size(), groups + 1);
    EXPECT_EQ(start[0], 0u);
    EXPECT_EQ(start[groups], labels.size());
    for (std::size_t g = 0; g < groups; ++g) {
        ASSERT_LE(start[g], start[g + 1]);
        for (std::uint32_t p = start[g]; p < start[g + 1]; ++p) EXPECT_EQ(labels[order[p]], static_cast<Label>(g));
    }
}

TEST(GroupByLabel, MatchesAStableSortByLabel) {
    std::mt19937 rng(19);
    for (int round = 0; round < 200; ++round) {
        const std::size_t groups = 1 + rng() % 40;
        std::vector<std::uint32_t> labels(rng() % 500);
        for (auto& l : labels) l = static_cast<std::uint32_t>(rng() % groups);
        expect_grouped_as_stable_sort(labels, groups);
    }
}

TEST(GroupByLabel, SmallLabelsAndEmptyGroups) {
    // Colours are bytes; groups in between may be empty, and so may the first and the last.
    expect_grouped_as_stable_sort<std::uint8_t>({3, 1, 3, 3, 1, 5}, 7);
    expect_grouped_as_stable_sort<std::uint8_t>({}, 3);
    expect_grouped_as_stable_sort<std::uint8_t>({0, 0, 0}, 1);
}

TEST(GroupByLabel, GroupStartsPointAtEachGroupsFirstItem) {
    const std::vector<std::uint32_t> labels{2, 0, 2, 1, 0};
    std::vector<std::uint32_t> start{0, 2, 1, 2};
    std::vector<std::uint32_t> order;
    group_by_label<std::uint32_t>(labels, start, order);
    EXPECT_EQ(order, (std::vector<std::uint32_t>{1, 4, 3, 0, 2}));
    EXPECT_EQ(start, (std::vector<std::uint32_t>{0, 2, 3, 5}));
}

}  // namespace
}  // namespace lockroll::sim

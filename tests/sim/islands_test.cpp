// Islands of the contact graph: links joined through dynamic bodies only, numbered by first
// link, each island's links ascending, and a pure function of the links.
#include <gtest/gtest.h>

#include <vector>

#include "sim/islands.h"

namespace lockroll::sim {
namespace {

constexpr std::uint32_t S = Islands::kStatic;

std::vector<std::vector<std::uint32_t>> groups(const Islands& is) {
    std::vector<std::vector<std::uint32_t>> out;
    for (std::size_t i = 0; i < is.count(); ++i) out.emplace_back(is.links(i).begin(), is.links(i).end());
    return out;
}

TEST(Islands, AChainIsOneIslandInLinkOrder) {
    Islands is;
    const std::vector<Islands::Link> links = {{0, 1}, {2, 3}, {1, 2}, {4, 5}};
    is.build(6, links);
    EXPECT_EQ(groups(is), (std::vector<std::vector<std::uint32_t>>{{0, 1, 2}, {3}}));
}

TEST(Islands, StaticBodiesJoinNothing) {
    Islands is;
    // Bodies 0 and 1 both rest on the floor (S); 2 rests on 0. Link 3 touches only statics.
    const std::vector<Islands::Link> links = {{0, S}, {S, 1}, {2, 0}, {S, S}, {1, S}};
    is.build(3, links);
    EXPECT_EQ(groups(is), (std::vector<std::vector<std::uint32_t>>{{0, 2}, {1, 4}, {3}}));
}

TEST(Islands, APureFunctionOfTheLinks) {
    Islands a, b;
    const std::vector<Islands::Link> big = {{5, 6}, {6, 7}, {0, 9}, {9, 8}, {3, S}};
    const std::vector<Islands::Link> small = {{1, 0}, {0, 2}};
    a.build(10, big);
    b.build(3, small);
    b.build(10, big);  // history must not matter
    EXPECT_EQ(groups(a), groups(b));
    EXPECT_EQ(groups(a), (std::vector<std::vector<std::uint32_t>>{{0, 1}, {2, 3}, {4}}));
    a.build(0, {});
    EXPECT_EQ(a.count(), 0u);
}

TEST(Islands, PiecesCoverEveryIslandInOrder) {
    Islands is;
    std::vector<Islands::Link> links;
    for (std::uint32_t k = 0; k < 40; ++k) links.push_back({k, k % 3 == 0 ? S : k + 100});
    is.build(200, links);
    ASSERT_EQ(is.count(), 40u);
    for (std::size_t pieces : {1u, 2u, 3u, 7u, 64u}) {
        EXPECT_EQ(is.first(pieces, 0), 0u);
        EXPECT_EQ(is.first(pieces, pieces), is.count());
        for (std::size_t k = 0; k < pieces; ++k) EXPECT_LE(is.first(pieces, k), is.first(pieces, k + 1));
    }
    EXPECT_EQ(is.first(2, 1), 20u);  // equal link counts: the middle island
}

}  // namespace
}  // namespace lockroll::sim

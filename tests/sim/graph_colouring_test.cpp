// Graph colouring of the contact manifolds (sim/graph_colouring.h): no two links of a colour
// share a dynamic body, static ends never conflict, greedy lowest colour in link order, an
// overflow group past kColours, and a pure function of the links.
#include <gtest/gtest.h>

#include <random>
#include <set>
#include <vector>

#include "sim/graph_colouring.h"

namespace lockroll::sim {
namespace {

constexpr std::uint32_t S = Islands::kStatic;
constexpr std::size_t K = GraphColouring::kColours;

std::vector<std::vector<std::uint32_t>> groups(const GraphColouring& g) {
    std::vector<std::vector<std::uint32_t>> out;
    for (std::size_t c = 0; c < K; ++c) out.emplace_back(g.colour(c).begin(), g.colour(c).end());
    out.emplace_back(g.overflow().begin(), g.overflow().end());
    return out;
}

// Every link in exactly one group, each group ascending, no colour with a dynamic body twice.
void expect_valid(const GraphColouring& g, const std::vector<Islands::Link>& links) {
    std::vector<int> seen(links.size(), 0);
    const auto all = groups(g);
    for (std::size_t c = 0; c < all.size(); ++c) {
        std::set<std::uint32_t> bodies;
        for (std::size_t i = 0; i < all[c].size(); ++i) {
            const std::uint32_t k = all[c][i];
            ASSERT_LT(k, links.size());
            ++seen[k];
            if (i > 0) {
                EXPECT_LT(all[c][i - 1], k) << "group " << c << " not ascending";
            }
            if (c == K) continue;  // the overflow may share bodies
            for (const std::uint32_t node : {links[k].a, links[k].b}) {
                if (node == S) continue;
                EXPECT_TRUE(bodies.insert(node).second) << "colour " << c << " holds body " << node << " twice";
            }
        }
    }
    for (std::size_t k = 0; k < links.size(); ++k) EXPECT_EQ(seen[k], 1) << "link " << k;
}

TEST(GraphColouring, GreedyLowestColourInLinkOrder) {
    GraphColouring g;
    // 0-1 takes 0; 1-2 conflicts on 1: colour 1; 2-3 conflicts with colour 1 (body 2): colour 0;
    // 4-5 is free: colour 0; 0-2 conflicts with 0 (body 0) and 1 (body 2): colour 2.
    const std::vector<Islands::Link> links = {{0, 1}, {1, 2}, {2, 3}, {4, 5}, {0, 2}};
    g.build(6, links);
    expect_valid(g, links);
    const auto all = groups(g);
    EXPECT_EQ(all[0], (std::vector<std::uint32_t>{0, 2, 3}));
    EXPECT_EQ(all[1], (std::vector<std::uint32_t>{1}));
    EXPECT_EQ(all[2], (std::vector<std::uint32_t>{4}));
    EXPECT_EQ(g.used_colours(), 3u);
    EXPECT_TRUE(g.overflow().empty());
}

TEST(GraphColouring, StaticBodiesNeverConflict) {
    GraphColouring g;
    // Every body rests on the floor (S), and one link touches only statics: all colour 0.
    const std::vector<Islands::Link> links = {{0, S}, {S, 1}, {2, S}, {S, S}, {S, 0}};
    g.build(3, links);
    expect_valid(g, links);
    // Body 0 twice: its second floor link must take colour 1.
    EXPECT_EQ(groups(g)[0], (std::vector<std::uint32_t>{0, 1, 2, 3}));
    EXPECT_EQ(groups(g)[1], (std::vector<std::uint32_t>{4}));
}

TEST(GraphColouring, OverflowPastTheLastColour) {
    GraphColouring g;
    // A hub body 0 touching K + 3 others: one colour each, then three in the overflow, in order.
    std::vector<Islands::Link> links;
    for (std::uint32_t k = 1; k <= K + 3; ++k) links.push_back({0, k});
    links.push_back({100, 101});  // free: colour 0 even after the overflow began
    g.build(102, links);
    expect_valid(g, links);
    EXPECT_EQ(g.used_colours(), K);
    EXPECT_EQ(std::vector<std::uint32_t>(g.overflow().begin(), g.overflow().end()),
              (std::vector<std::uint32_t>{static_cast<std::uint32_t>(K), static_cast<std::uint32_t>(K + 1),
                                          static_cast<std::uint32_t>(K + 2)}));
    EXPECT_EQ(groups(g)[0], (std::vector<std::uint32_t>{0, static_cast<std::uint32_t>(K + 3)}));
}

TEST(GraphColouring, RandomGraphsValidAndAPureFunctionOfTheLinks) {
    std::mt19937 rng(19);
    GraphColouring reused;
    for (int round = 0; round < 20; ++round) {
        const std::uint32_t nodes = 20 + static_cast<std::uint32_t>(rng() % 2000);
        std::vector<Islands::Link> links;
        const std::size_t count = rng() % (4 * nodes);
        for (std::size_t k = 0; k < count; ++k) {
            const auto end = [&] { return rng() % 8 == 0 ? S : static_cast<std::uint32_t>(rng() % nodes); };
            Islands::Link l{end(), end()};
            if (l.a == l.b && l.a != S) l.b = S;  // no manifold joins a body to itself
            links.push_back(l);
        }
        reused.build(nodes, links);  // after other graphs: history must not matter
        expect_valid(reused, links);
        GraphColouring fresh;
        fresh.build(nodes, links);
        EXPECT_EQ(groups(reused), groups(fresh));
    }
    reused.build(0, {});
    EXPECT_EQ(reused.used_colours(), 0u);
    EXPECT_TRUE(reused.overflow().empty());
}

}  // namespace
}  // namespace lockroll::sim

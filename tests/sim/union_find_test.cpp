// sim/union_find.h: the components of the links joined, each rooted at its smallest node
// whatever the order of the unions, checked against a plain graph search on random graphs;
// nodes made alone one by one; and path halving keeping the trees shallow.
#include "sim/union_find.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

namespace lockroll::sim {
namespace {

using Edges = std::vector<std::pair<std::uint32_t, std::uint32_t>>;

// Each node's smallest reachable node, by depth-first search over the edges.
std::vector<std::uint32_t> smallest_reachable(std::uint32_t n, const Edges& edges) {
    std::vector<std::vector<std::uint32_t>> adj(n);
    for (auto [a, b] : edges) {
        adj[a].push_back(b);
        adj[b].push_back(a);
    }
    std::vector<std::uint32_t> out(n, n);
    for (std::uint32_t s = 0; s < n; ++s) {  // ascending: s is its component's smallest
        if (out[s] != n) continue;
        std::vector<std::uint32_t> stack{s};
        out[s] = s;
        while (!stack.empty()) {
            const std::uint32_t x = stack.back();
            stack.pop_back();
            for (std::uint32_t y : adj[x])
                if (out[y] == n) {
                    out[y] = s;
                    stack.push_back(y);
                }
        }
    }
    return out;
}

TEST(UnionFind, EveryNodeStartsAlone) {
    UnionFind uf;
    uf.reset(5);
    for (std::uint32_t x = 0; x < 5; ++x) EXPECT_EQ(uf.find(x), x);
}

TEST(UnionFind, TheSmallestNodeIsTheRootWhateverTheOrder) {
    UnionFind uf;
    uf.reset(6);
    uf.unite(5, 4);  // 4 is the root, not the first argument
    EXPECT_EQ(uf.find(5), 4u);
    uf.unite(3, 5);
    uf.unite(2, 1);
    EXPECT_EQ(uf.find(4), 3u);
    EXPECT_EQ(uf.find(2), 1u);
    uf.unite(4, 2);
    for (std::uint32_t x : {1u, 2u, 3u, 4u, 5u}) EXPECT_EQ(uf.find(x), 1u);
    EXPECT_EQ(uf.find(0), 0u);
    uf.unite(3, 3);  // a self link and a link within a component change nothing
    uf.unite(5, 2);
    for (std::uint32_t x : {1u, 2u, 3u, 4u, 5u}) EXPECT_EQ(uf.find(x), 1u);
}

TEST(UnionFind, RandomGraphsMatchASearch) {
    std::mt19937 rng(19);
    for (int round = 0; round < 200; ++round) {
        const std::uint32_t n = 1 + rng() % 60;
        Edges edges(rng() % (2 * n));
        for (auto& [a, b] : edges) a = rng() % n, b = rng() % n;
        const std::vector<std::uint32_t> expected = smallest_reachable(n, edges);
        // The roots are the same whatever the order of the links.
        for (int order = 0; order < 3; ++order) {
            std::shuffle(edges.begin(), edges.end(), rng);
            UnionFind uf;
            uf.reset(n);
            for (auto [a, b] : edges) uf.unite(a, b);
            for (std::uint32_t x = 0; x < n; ++x) ASSERT_EQ(uf.find(x), expected[x]) << "round " << round << " node " << x;
        }
    }
}

TEST(UnionFind, ResetForgetsHistoryAndIsolateOneNode) {
    UnionFind uf;
    uf.reset(8);
    for (std::uint32_t x = 0; x + 1 < 8; ++x) uf.unite(x, x + 1);
    EXPECT_EQ(uf.find(7), 0u);
    // Only the odd nodes alone again (a caller joining a subset): they join among themselves.
    for (std::uint32_t x = 1; x < 8; x += 2) uf.isolate(x);
    uf.unite(7, 5);
    uf.unite(3, 7);
    EXPECT_EQ(uf.find(5), 3u);
    EXPECT_EQ(uf.find(7), 3u);
    EXPECT_EQ(uf.find(1), 1u);
    uf.reset(8);
    for (std::uint32_t x = 0; x < 8; ++x) EXPECT_EQ(uf.find(x), x);
}

TEST(UnionFind, FindHalvesThePath) {
    // A chain 0 <- 1 <- ... <- 8 built by hand (each node's parent the one before): a find from
    // the far end points every other node on the path at its grandparent.
    UnionFind uf;
    uf.reset(9);
    const auto parent = uf.parents();
    for (std::uint32_t x = 1; x < 9; ++x) parent[x] = x - 1;
    EXPECT_EQ(uf.find(8), 0u);
    EXPECT_EQ(parent[8], 6u);
    EXPECT_EQ(parent[6], 4u);
    EXPECT_EQ(parent[4], 2u);
    EXPECT_EQ(parent[2], 0u);
    EXPECT_EQ(parent[7], 6u);  // off the halved path: unchanged
    for (std::uint32_t x = 0; x < 9; ++x) EXPECT_EQ(uf.find(x), 0u);
}

}  // namespace
}  // namespace lockroll::sim

// Islands of the contact graph: links joined through dynamic bodies only, numbered by first
// link, each island's links ascending, and a pure function of the links.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <random>
#include <thread>
#include <vector>

#include "sim/islands.h"
#include "sim/parallel_tasks.h"

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

// Every task on a thread of its own, all at once (the union-find's ranges race for real).
void run_on_threads(std::size_t count, const std::function<void(std::size_t)>& task) {
    std::vector<std::thread> threads;
    for (std::size_t i = 0; i < count; ++i) threads.emplace_back([&task, i] { task(i); });
    for (std::thread& t : threads) t.join();
}

void run_backwards(std::size_t count, const std::function<void(std::size_t)>& task) {
    for (std::size_t i = count; i-- > 0;) task(i);
}

// Random graphs: a few long chains joined in shuffled order (deep trees, roots linked late,
// links ascending and descending), many small clusters, links to the floor, static pairs.
std::vector<Islands::Link> random_links(std::size_t nodes, std::size_t count, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::vector<Islands::Link> links;
    const auto node = [&](std::size_t below) { return static_cast<std::uint32_t>(rng() % below); };
    const std::size_t chain = nodes / 4;
    for (std::uint32_t i = 0; i + 1 < chain; ++i) links.push_back({i, i + 1});
    while (links.size() < count) {
        const std::uint32_t a = node(nodes);
        switch (rng() % 8) {
            case 0: links.push_back({a, S}); break;
            case 1: links.push_back({S, a}); break;
            case 2: links.push_back({S, S}); break;
            default: {
                const std::uint32_t b = std::min<std::uint32_t>(static_cast<std::uint32_t>(nodes - 1), a + node(6));
                links.push_back({a, b});
            }
        }
    }
    std::shuffle(links.begin(), links.end(), rng);
    return links;
}

TEST(Islands, ParallelBuildMatchesSequentialAtAnyCut) {
    for (const std::uint32_t seed : {1u, 2u, 3u}) {
        for (const std::size_t nodes : {50u, 3000u, 20000u}) {
            const std::vector<Islands::Link> links = random_links(nodes, nodes * 2, seed);
            Islands sequential;
            sequential.build(nodes, links);
            for (const TaskRunner& runner : {TaskRunner(run_on_threads), TaskRunner(run_backwards)}) {
                for (const int chunks : {2, 3, 5, 8}) {
                    Islands parallel;
                    parallel.build(nodes, random_links(nodes / 2 + 1, nodes, seed + 7));  // history must not matter
                    parallel.build(nodes, links, ParallelTasks(chunks, runner));
                    ASSERT_EQ(groups(parallel), groups(sequential))
                        << "seed " << seed << ", " << nodes << " nodes, " << chunks << " chunks";
                }
            }
        }
    }
}

}  // namespace
}  // namespace lockroll::sim

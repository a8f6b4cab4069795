// Islands of a step's contact graph, for the parallel step (docs/physics.md, "Parallel step").
//
// Nodes are bodies; each link (a contact manifold, or a candidate pair) joins its two ends.
// A static body joins no island (pass kStatic for that end): it is never written by a row, so
// two islands that both rest on the floor still touch disjoint state. An island is then a set
// of links whose rows write only its own bodies, and Gauss-Seidel over the links of one island
// in their global relative order gives the same bits as one sweep over every link: the rows
// of other islands in between read and write none of its state.
//
// Contracts: islands are numbered in the order of their first link; links(i) lists island i's
// links ascending. A link with no dynamic end (both kStatic) is an island of its own. Both
// are pure functions of the links, never of history. build() allocates only to grow.
//
// With tasks that run in parallel, build() joins the links and finds each link's root in
// ranges of links (a lock-free union-find: docs/physics.md, "Parallel step"); the components,
// so the islands, are the same whatever the cut, and the numbering and grouping that follow
// are the sequential ones.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "sim/parallel_tasks.h"
#include "sim/union_find.h"

namespace lockroll::sim {

class Islands {
public:
    static constexpr std::uint32_t kStatic = ~std::uint32_t{0};
    struct Link {
        std::uint32_t a, b;  // node ids below `nodes`, or kStatic
    };

    void build(std::size_t nodes, std::span<const Link> links);
    void build(std::size_t nodes, std::span<const Link> links, const ParallelTasks& tasks);

    std::size_t count() const { return start_.empty() ? 0 : start_.size() - 1; }
    std::span<const std::uint32_t> links(std::size_t island) const {
        return {order_.data() + start_[island], start_[island + 1] - start_[island]};
    }
    // The first island of piece k when islands are cut into `pieces` contiguous runs of about
    // equal link counts (first(pieces, pieces) == count()). Any cut gives the same results.
    std::size_t first(std::size_t pieces, std::size_t k) const;

private:
    // Links per range of the parallel union-find, at least.
    static constexpr std::size_t kLinkGrain = 1024;

    // forest_'s parents in the parallel build: every access atomic (std::atomic_ref or the
    // __atomic builtins, islands.cpp), so ranges on other threads may join and walk the same
    // trees.
    void unite_concurrent(std::uint32_t a, std::uint32_t b);
    std::uint32_t find_concurrent(std::uint32_t x);
    std::uint32_t root_after_unite(std::uint32_t x);
    // The numbering and grouping from each link's root (kStatic for a link with no dynamic end).
    void group(std::span<const std::uint32_t> link_root);

    UnionFind forest_;                           // by node
    std::vector<std::uint32_t> label_;           // by node
    std::vector<std::uint32_t> link_root_;       // by link: its root, or kStatic
    std::vector<std::uint32_t> island_of_;       // by link
    std::vector<std::uint32_t> start_, order_;   // links grouped by island
};

}  // namespace lockroll::sim

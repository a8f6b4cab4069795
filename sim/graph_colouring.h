// Graph colouring of a step's contact manifolds, for the rigid solver's coloured passes
// (rigid.graph_colouring; docs/physics.md, "Graph-coloured rows").
//
// Nodes are bodies, each link (a manifold) joins its two ends, as in sim/islands.h: a static
// body is passed as Islands::kStatic and never conflicts (no row writes it). Greedy, in link
// order: each link takes the lowest colour in which neither of its dynamic ends is already
// used; a link for which all kColours are taken goes to the overflow group. So no two links of
// one colour share a dynamic body, and a colour's rows may run in any order, on any threads,
// with the same bits.
//
// Contracts: colour(c) lists colour c's links ascending, overflow() the overflow links
// ascending; every link is in exactly one of them. A pure function of the links (so of the
// manifold order and the bodies), never of history or of any worker count. build() allocates
// only to grow.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "sim/islands.h"

namespace lockroll::sim {

class GraphColouring {
public:
    // Box2D v3 uses 24 colours; the settled bodies_10k_rigid pile needs fewer
    // (docs/performance.md, "Graph-coloured rows").
    static constexpr std::size_t kColours = 24;

    void build(std::size_t nodes, std::span<const Islands::Link> links);

    // Groups 0 .. kColours - 1 are the colours (possibly empty), group kColours the overflow.
    static constexpr std::size_t kGroups = kColours + 1;
    std::span<const std::uint32_t> group(std::size_t g) const {
        return {order_.data() + start_[g], start_[g + 1] - start_[g]};
    }
    std::span<const std::uint32_t> colour(std::size_t c) const { return group(c); }
    std::span<const std::uint32_t> overflow() const { return group(kColours); }
    // Every link, group after group: group g is order()[group_start(g), group_start(g + 1)).
    std::span<const std::uint32_t> order() const { return order_; }
    std::size_t group_start(std::size_t g) const { return start_[g]; }
    // Colours that hold at least one link.
    std::size_t used_colours() const;

private:

    std::vector<std::uint32_t> used_;        // by node: bit c set when colour c holds one of its links
    std::vector<std::uint8_t> colour_of_;    // by link: its colour, or kColours for the overflow
    std::vector<std::uint32_t> start_ = std::vector<std::uint32_t>(kColours + 2, 0);
    std::vector<std::uint32_t> order_;       // links grouped by colour, ascending within each
};

}  // namespace lockroll::sim

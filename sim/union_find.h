// Union-find over node ids [0, n): the connected components of links joined one by one, and
// nothing else (no numbering or grouping: sim/islands.h does that on top of it).
//
// Contracts:
//  - Deterministic: no ranks, sizes or randomness. When two roots meet, the smaller id becomes
//    the root of both, so every component's root, find(x), is its smallest node, whatever the
//    order of the unite() calls; the forest itself is a function of that sequence alone.
//  - find() halves the path it walks (each node it passes is pointed at its grandparent): the
//    trees stay shallow without recursion or a second pass; roots never change in find().
//  - Only the nodes a caller uses need be alone first: reset(n) makes all of [0, n) alone,
//    isolate(x) one (for a caller that joins a subset of ids, e.g. the awake bodies); find()
//    and unite() on a node neither made alone since the last reset() read stale parents.
//  - Allocates only in reset(), to grow.
// Islands' lock-free parallel build reaches the same parents through parents() with atomic
// accesses (sim/islands.cpp); the root rule is the same there.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace lockroll::sim {

class UnionFind {
public:
    // Nodes [0, n), each alone.
    void reset(std::size_t n) {
        parent_.resize(n);
        for (std::size_t i = 0; i < n; ++i) parent_[i] = static_cast<std::uint32_t>(i);
    }
    // Node x (below the last reset's n) alone again.
    void isolate(std::uint32_t x) { parent_[x] = x; }

    std::uint32_t find(std::uint32_t x) {
        while (parent_[x] != x) {
            parent_[x] = parent_[parent_[x]];  // path halving
            x = parent_[x];
        }
        return x;
    }
    // Joins a's and b's components under the smaller of their roots.
    void unite(std::uint32_t a, std::uint32_t b) {
        const std::uint32_t ra = find(a), rb = find(b);
        if (ra < rb)
            parent_[rb] = ra;
        else if (rb < ra)
            parent_[ra] = rb;
    }

    std::span<std::uint32_t> parents() { return parent_; }

private:
    std::vector<std::uint32_t> parent_;  // by node; a root is its own parent
};

}  // namespace lockroll::sim

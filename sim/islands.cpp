#include "sim/islands.h"

#include <algorithm>
#include <atomic>
#include <utility>

#include "sim/group_by_label.h"

namespace lockroll::sim {

namespace {
// forest_'s parents' atomic accesses in the parallel build. std::atomic_ref where the standard
// library has it; libc++ 14 (the WebAssembly build's, scripts/cross-check.sh) has not, and there the
// same operations go through the compiler's __atomic builtins (gcc and clang both have them).
#if defined(__cpp_lib_atomic_ref)
std::uint32_t load(std::uint32_t& x, std::memory_order order) { return std::atomic_ref<std::uint32_t>(x).load(order); }
void store(std::uint32_t& x, std::uint32_t v) { std::atomic_ref<std::uint32_t>(x).store(v, std::memory_order_release); }
bool replace(std::uint32_t& x, std::uint32_t expected, std::uint32_t desired) {
    return std::atomic_ref<std::uint32_t>(x).compare_exchange_strong(expected, desired, std::memory_order_acq_rel);
}
#else
std::uint32_t load(std::uint32_t& x, std::memory_order order) {
    return order == std::memory_order_relaxed ? __atomic_load_n(&x, __ATOMIC_RELAXED) : __atomic_load_n(&x, __ATOMIC_ACQUIRE);
}
void store(std::uint32_t& x, std::uint32_t v) { __atomic_store_n(&x, v, __ATOMIC_RELEASE); }
bool replace(std::uint32_t& x, std::uint32_t expected, std::uint32_t desired) {
    return __atomic_compare_exchange_n(&x, &expected, desired, false, __ATOMIC_ACQ_REL, __ATOMIC_ACQUIRE);
}
#endif
}  // namespace

void Islands::build(std::size_t nodes, std::span<const Link> links) {
    // The smaller root wins (sim/union_find.h): the forest is a function of the links alone.
    forest_.reset(nodes);
    for (const Link& l : links)
        if (l.a != kStatic && l.b != kStatic) forest_.unite(l.a, l.b);
    link_root_.resize(links.size());
    for (std::size_t k = 0; k < links.size(); ++k) {
        const std::uint32_t node = links[k].a != kStatic ? links[k].a : links[k].b;
        link_root_[k] = node == kStatic ? kStatic : forest_.find(node);
    }
    label_.assign(nodes, kStatic);
    group(link_root_);
}

void Islands::build(std::size_t nodes, std::span<const Link> links, const ParallelTasks& tasks) {
    const std::size_t pieces = tasks.piece_count(links.size(), kLinkGrain);
    if (pieces <= 1) {
        build(nodes, links);
        return;
    }
    forest_.reset(nodes);
    const std::size_t n = links.size();
    const auto range = [&](std::size_t k, auto&& body) {
        for (std::size_t i = n * k / pieces, e = n * (k + 1) / pieces; i < e; ++i) body(links[i], i);
    };
    // 1. Join every link's ends. The trees change under each range, but the components they
    //    end with are the graph's, and each component's root is its smallest node (a root is
    //    only ever linked under a smaller one), as in the sequential build.
    tasks.run(pieces, [&](std::size_t k) {
        range(k, [&](const Link& l, std::size_t) {
            if (l.a != kStatic && l.b != kStatic) unite_concurrent(l.a, l.b);
        });
    });
    // 2. Each link's root, reading the finished trees (no writes, so no range can see a tree
    //    change under it).
    link_root_.resize(n);
    tasks.run(pieces, [&](std::size_t k) {
        range(k, [&](const Link& l, std::size_t i) {
            const std::uint32_t node = l.a != kStatic ? l.a : l.b;
            link_root_[i] = node == kStatic ? kStatic : root_after_unite(node);
        });
    });
    // 3. Numbered by first link and grouped, sequentially (one pass over the roots).
    label_.assign(nodes, kStatic);
    group(link_root_);
}

void Islands::unite_concurrent(std::uint32_t a, std::uint32_t b) {
    const std::span<std::uint32_t> parent = forest_.parents();
    for (;;) {
        std::uint32_t ra = find_concurrent(a), rb = find_concurrent(b);
        if (ra == rb) return;
        if (rb < ra) std::swap(ra, rb);
        // Link the larger root under the smaller, if it is still a root (another range may
        // have linked it meanwhile: then walk up again).
        if (replace(parent[rb], rb, ra)) return;
    }
}

std::uint32_t Islands::find_concurrent(std::uint32_t x) {
    const std::span<std::uint32_t> parent = forest_.parents();
    for (;;) {
        const std::uint32_t p = load(parent[x], std::memory_order_acquire);
        if (p == x) return x;
        const std::uint32_t gp = load(parent[p], std::memory_order_acquire);
        // Path halving. x is not a root, so nothing links x any more; other threads only
        // shorten its path too, and any ancestor of x is a correct parent for it.
        if (gp != p) store(parent[x], gp);
        x = gp;
    }
}

std::uint32_t Islands::root_after_unite(std::uint32_t x) {
    // Other ranges read the same trees at the same time; nothing writes them any more, but
    // the parents are reached atomically everywhere in the parallel build for the race
    // detector's sake (relaxed loads cost a plain load).
    const std::span<std::uint32_t> parent = forest_.parents();
    for (;;) {
        const std::uint32_t p = load(parent[x], std::memory_order_relaxed);
        if (p == x) return x;
        x = p;
    }
}

void Islands::group(std::span<const std::uint32_t> link_root) {
    island_of_.resize(link_root.size());
    start_.assign(1, 0);
    for (std::size_t k = 0; k < link_root.size(); ++k) {
        std::uint32_t island;
        if (link_root[k] == kStatic) {
            island = static_cast<std::uint32_t>(start_.size() - 1);
        } else {
            std::uint32_t& label = label_[link_root[k]];
            if (label == kStatic) label = static_cast<std::uint32_t>(start_.size() - 1);
            island = label;
        }
        if (island == start_.size() - 1) start_.push_back(0);
        island_of_[k] = island;
        ++start_[island + 1];
    }
    group_by_label<std::uint32_t>(island_of_, start_, order_);
}

std::size_t Islands::first(std::size_t pieces, std::size_t k) const {
    if (k >= pieces) return count();
    const std::size_t target = static_cast<std::size_t>(order_.size()) * k / pieces;
    // The first island whose links start at or after the target.
    const auto it = std::lower_bound(start_.begin(), start_.end() - 1, static_cast<std::uint32_t>(target));
    return static_cast<std::size_t>(it - start_.begin());
}

}  // namespace lockroll::sim

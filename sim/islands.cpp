#include "sim/islands.h"

#include <algorithm>

namespace lockroll::sim {

std::uint32_t Islands::find(std::uint32_t x) {
    while (parent_[x] != x) {
        parent_[x] = parent_[parent_[x]];  // path halving
        x = parent_[x];
    }
    return x;
}

void Islands::build(std::size_t nodes, std::span<const Link> links) {
    parent_.resize(nodes);
    for (std::size_t i = 0; i < nodes; ++i) parent_[i] = static_cast<std::uint32_t>(i);
    for (const Link& l : links) {
        if (l.a == kStatic || l.b == kStatic) continue;
        const std::uint32_t ra = find(l.a), rb = find(l.b);
        // The smaller root wins: the forest is a function of the links alone.
        if (ra < rb)
            parent_[rb] = ra;
        else if (rb < ra)
            parent_[ra] = rb;
    }
    label_.assign(nodes, kStatic);
    island_of_.resize(links.size());
    start_.assign(1, 0);
    for (std::size_t k = 0; k < links.size(); ++k) {
        const std::uint32_t node = links[k].a != kStatic ? links[k].a : links[k].b;
        std::uint32_t island;
        if (node == kStatic) {
            island = static_cast<std::uint32_t>(start_.size() - 1);
        } else {
            std::uint32_t& label = label_[find(node)];
            if (label == kStatic) label = static_cast<std::uint32_t>(start_.size() - 1);
            island = label;
        }
        if (island == start_.size() - 1) start_.push_back(0);
        island_of_[k] = island;
        ++start_[island + 1];
    }
    for (std::size_t i = 1; i < start_.size(); ++i) start_[i] += start_[i - 1];
    order_.resize(links.size());
    // Counting sort, stable: each island's links stay ascending. Uses label_ as the cursor.
    label_.assign(start_.begin(), start_.end() - 1);
    for (std::size_t k = 0; k < links.size(); ++k) order_[label_[island_of_[k]]++] = static_cast<std::uint32_t>(k);
}

std::size_t Islands::first(std::size_t pieces, std::size_t k) const {
    if (k >= pieces) return count();
    const std::size_t target = static_cast<std::size_t>(order_.size()) * k / pieces;
    // The first island whose links start at or after the target.
    const auto it = std::lower_bound(start_.begin(), start_.end() - 1, static_cast<std::uint32_t>(target));
    return static_cast<std::size_t>(it - start_.begin());
}

}  // namespace lockroll::sim

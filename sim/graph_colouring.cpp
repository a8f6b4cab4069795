#include "sim/graph_colouring.h"

#include <algorithm>
#include <bit>

#include "sim/group_by_label.h"

namespace lockroll::sim {

static_assert(GraphColouring::kColours <= 32, "a node's used colours are one 32-bit mask");

void GraphColouring::build(std::size_t nodes, std::span<const Islands::Link> links) {
    constexpr std::uint32_t kAll = GraphColouring::kColours == 32 ? ~std::uint32_t{0}
                                                                 : (std::uint32_t{1} << kColours) - 1;
    used_.assign(nodes, 0);
    colour_of_.resize(links.size());
    std::fill(start_.begin(), start_.end(), 0);
    const auto mask = [&](std::uint32_t node) { return node == Islands::kStatic ? 0 : used_[node]; };
    for (std::size_t k = 0; k < links.size(); ++k) {
        const Islands::Link& l = links[k];
        const std::uint32_t free = ~(mask(l.a) | mask(l.b)) & kAll;
        std::size_t c = kColours;  // overflow: every colour holds one of its bodies
        if (free != 0) {
            c = static_cast<std::size_t>(std::countr_zero(free));
            const std::uint32_t bit = std::uint32_t{1} << c;
            if (l.a != Islands::kStatic) used_[l.a] |= bit;
            if (l.b != Islands::kStatic) used_[l.b] |= bit;
        }
        colour_of_[k] = static_cast<std::uint8_t>(c);
        ++start_[c + 1];
    }
    group_by_label<std::uint8_t>(colour_of_, start_, order_);
}

std::size_t GraphColouring::used_colours() const {
    std::size_t n = 0;
    for (std::size_t c = 0; c < kColours; ++c) n += start_[c + 1] != start_[c] ? 1 : 0;
    return n;
}

}  // namespace lockroll::sim

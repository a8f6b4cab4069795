// group_by_label: a stable counting sort of items by a small label, the one place the step
// groups links by island (sim/islands.cpp) or by colour (sim/graph_colouring.cpp).
//
// Why a counting sort: the labels are dense (0 .. groups - 1) and the items already in the
// order each group must keep (a step's links in pair order), so one prefix sum and one pass
// place every item, with no comparison and no scratch beyond the output.
//
// Contract: on entry start.size() == groups + 1, start[0] == 0 and start[g + 1] is how many
// items carry label g (label_of[k] < groups for every k). On return start[g] is group g's
// first place in order and start[groups] == label_of.size(); order lists the item indexes
// grouped by label, ascending within each group. order is resized; nothing else allocates.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace lockroll::sim {

template <class Label>
void group_by_label(std::span<const Label> label_of, std::span<std::uint32_t> start, std::vector<std::uint32_t>& order) {
    for (std::size_t g = 1; g < start.size(); ++g) start[g] += start[g - 1];
    order.resize(label_of.size());
    // start[g] serves as group g's cursor while placing, so it ends at group g + 1's first
    // place; shifting by one restores every group's start.
    for (std::size_t k = 0; k < label_of.size(); ++k) order[start[label_of[k]]++] = static_cast<std::uint32_t>(k);
    for (std::size_t g = start.size() - 1; g > 0; --g) start[g] = start[g - 1];
    start[0] = 0;
}

}  // namespace lockroll::sim

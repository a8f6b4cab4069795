#include "rollback/arbitration.h"

#include <bit>

namespace lockroll::rollback {

int ArbitrationVerdict::lowest_winner() const { return winners ? std::countr_zero(winners) : -1; }

ArbitrationVerdict arbitrate(std::span<const std::uint64_t> values, std::uint64_t voted, int view_size,
                             const ArbitrationRule& rule) {
    if (values.size() < 64) voted &= (std::uint64_t{1} << values.size()) - 1;
    ArbitrationVerdict v;
    v.voters = std::popcount(voted);
    if (v.voters == 0) return v;
    // Groups are visited by their lowest voter, ascending, so "the first of the biggest" is the
    // tied group whose lowest voter is lowest. At most 64 voters: quadratic costs nothing here.
    int best_size = 0;
    int groups_of_best_size = 0;
    std::uint64_t seen = 0;
    for (std::uint64_t rest = voted; rest; rest &= rest - 1) {
        const int first = std::countr_zero(rest);
        if ((seen >> first) & 1u) continue;  // its group was counted from a lower voter
        const std::uint64_t value = values[static_cast<std::size_t>(first)];
        std::uint64_t group = 0;
        for (std::uint64_t r = rest; r; r &= r - 1) {
            const int w = std::countr_zero(r);
            if (values[static_cast<std::size_t>(w)] == value) group |= std::uint64_t{1} << w;
        }
        seen |= group;
        const int size = std::popcount(group);
        if (size > best_size) {
            best_size = size;
            groups_of_best_size = 1;
            v.winners = group;
            v.value = value;
        } else if (size == best_size) {
            ++groups_of_best_size;
            if (rule.tie == ArbitrationTie::HighestSlot) {
                v.winners = group;
                v.value = value;
            }
        }
    }
    v.tie_broken = groups_of_best_size > 1;
    v.strict_majority = 2 * best_size > v.voters;
    if (v.voters == 2 && view_size == 2 && !v.strict_majority && rule.two_alone_no_majority) {
        v.no_majority = true;
        v.winners = 0;
        v.value = 0;
        v.minority = voted;
        return v;
    }
    v.minority = voted & ~v.winners;
    return v;
}

}  // namespace lockroll::rollback

#include "rollback/recovery_source.h"

#include <algorithm>
#include <map>
#include <vector>

namespace lockroll::rollback {

std::optional<PlayerId> recovery_source(PlayerId me, std::uint64_t mine,
                                        std::span<const std::pair<PlayerId, std::uint64_t>> theirs, DesyncKeep keep) {
    // value (low 32 bits) -> slots holding it
    std::map<std::uint32_t, std::vector<PlayerId>> groups;
    groups[static_cast<std::uint32_t>(mine)].push_back(me);
    for (const auto& [slot, value] : theirs) groups[static_cast<std::uint32_t>(value)].push_back(slot);
    const std::vector<PlayerId>* best = nullptr;
    for (auto& [value, slots] : groups) {
        std::sort(slots.begin(), slots.end());
        if (!best || slots.size() > best->size()) {
            best = &slots;
        } else if (slots.size() == best->size()) {
            const bool lower = slots.front() < best->front();
            if (lower == (keep == DesyncKeep::LowestSlot)) best = &slots;
        }
    }
    if (std::find(best->begin(), best->end(), me) != best->end()) return std::nullopt;  // the odd ones reload
    return best->front();
}

}  // namespace lockroll::rollback

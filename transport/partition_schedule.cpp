#include "transport/partition_schedule.h"

#include <algorithm>
#include <stdexcept>

namespace lockroll::transport {

int PartitionCut::side_of(PeerId slot) const {
    for (std::size_t s = 0; s < sets.size(); ++s)
        if (std::find(sets[s].begin(), sets[s].end(), slot) != sets[s].end()) return static_cast<int>(s);
    return -1;
}

std::string validate(const PartitionCut& cut) {
    if (cut.sets.size() < 2)
        return "a cut needs at least two sets of slots (got " + std::to_string(cut.sets.size()) + ")";
    std::vector<PeerId> seen;
    for (std::size_t s = 0; s < cut.sets.size(); ++s) {
        if (cut.sets[s].empty()) return "set " + std::to_string(s + 1) + " is empty";
        for (const PeerId slot : cut.sets[s]) {
            if (std::find(seen.begin(), seen.end(), slot) != seen.end())
                return "slot " + std::to_string(slot) + " is named twice (sets must not overlap)";
            seen.push_back(slot);
        }
    }
    if (cut.from_us >= cut.until_us)
        return "the cut must start before it ends (from " + std::to_string(cut.from_us) + " us, until " +
               std::to_string(cut.until_us) + " us)";
    return {};
}

void PartitionSchedule::add(PartitionCut cut) {
    if (const std::string err = validate(cut); !err.empty()) throw std::invalid_argument("partition: " + err);
    cuts_.push_back(std::move(cut));
}

bool PartitionSchedule::is_cut(PeerId from, PeerId to, Micros now) const {
    for (const PartitionCut& c : cuts_) {
        if (now < c.from_us || now >= c.until_us) continue;
        const int a = c.side_of(from);
        if (a < 0) continue;
        const int b = c.side_of(to);
        if (b >= 0 && b != a) return true;
    }
    return false;
}

PartitionSchedule PartitionSchedule::shifted(Micros offset_us) const {
    PartitionSchedule out = *this;
    for (PartitionCut& c : out.cuts_) {
        c.from_us += offset_us;
        c.until_us += offset_us;
    }
    return out;
}

std::string PartitionSchedule::check_slots(int peers) const {
    for (const PartitionCut& c : cuts_)
        for (const auto& set : c.sets)
            for (const PeerId slot : set)
                if (peers < 1 || slot >= static_cast<PeerId>(peers))
                    return "slot " + std::to_string(slot) + " is not in 0.." + std::to_string(peers - 1);
    return {};
}

}  // namespace lockroll::transport

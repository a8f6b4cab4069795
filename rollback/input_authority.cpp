#include "rollback/input_authority.h"

#include <algorithm>
#include <bit>

namespace lockroll::rollback {

namespace {
constexpr auto by_frame = [](const auto& record, std::uint32_t frame) { return record.frame < frame; };
}  // namespace

InputAuthority::InputAuthority(int players, int peers)
    : records_(static_cast<std::size_t>(std::max(players, 0))),
      ignored_(static_cast<std::size_t>(std::max(peers, 0)), false),
      counts_(static_cast<std::size_t>(std::max(peers, 0)), 0) {}

InputAuthority::Records::iterator InputAuthority::find(PlayerId slot, std::uint32_t frame) {
    Records& r = records_[slot];
    const auto it = std::lower_bound(r.begin(), r.end(), frame, by_frame);
    return it != r.end() && it->frame == frame ? it : r.end();
}

InputAuthority::Records::const_iterator InputAuthority::find(PlayerId slot, std::uint32_t frame) const {
    const Records& r = records_[slot];
    const auto it = std::lower_bound(r.begin(), r.end(), frame, by_frame);
    return it != r.end() && it->frame == frame ? it : r.end();
}

void InputAuthority::note_relayed(PlayerId slot, std::uint32_t frame, PlayerId relay) {
    if (slot >= records_.size()) return;
    Records& r = records_[slot];
    if (!r.empty() && r.back().frame >= frame) return;
    r.push_back({frame, relay});
}

void InputAuthority::vouch(PlayerId slot, std::uint32_t frame, PlayerId relay) {
    if (slot >= records_.size()) return;
    const auto it = find(slot, frame);
    if (it != records_[slot].end() && it->relay != relay) it->vouched = true;
}

std::optional<PlayerId> InputAuthority::relay_of(PlayerId slot, std::uint32_t frame) const {
    if (slot >= records_.size()) return std::nullopt;
    const auto it = find(slot, frame);
    if (it == records_[slot].end()) return std::nullopt;
    return it->relay;
}

void InputAuthority::dispute(PlayerId slot, std::uint32_t frame, PlayerId relay) {
    if (slot >= records_.size() || relay >= 64) return;
    const auto it = find(slot, frame);
    if (it != records_[slot].end() && it->relay != relay) it->disputers |= std::uint64_t{1} << relay;
}

std::uint64_t InputAuthority::verified(PlayerId slot, std::uint32_t frame) {
    if (slot >= records_.size()) return 0;
    const auto it = find(slot, frame);
    if (it == records_[slot].end() || it->contradicted) return 0;
    const std::uint64_t wrong = it->disputers;
    for (std::uint64_t w = wrong; w != 0; w &= w - 1) relay_disagrees(static_cast<PlayerId>(std::countr_zero(w)));
    records_[slot].erase(it);
    return wrong;
}

bool InputAuthority::owner_disagrees(PlayerId slot, std::uint32_t frame, bool replaced) {
    if (slot >= records_.size()) return false;
    const auto it = find(slot, frame);
    if (it == records_[slot].end()) return false;
    const bool first_time = !it->contradicted;
    if (first_time && it->relay < counts_.size()) {
        ++counts_[it->relay];
        ignored_[it->relay] = true;
    }
    if (replaced)
        records_[slot].erase(it);
    else
        it->contradicted = true;
    return first_time;
}

void InputAuthority::relay_disagrees(PlayerId relay) {
    if (relay >= counts_.size()) return;
    ++counts_[relay];
    ignored_[relay] = true;
}

std::optional<std::uint32_t> InputAuthority::first_unverified_of(PlayerId slot, std::uint32_t from) const {
    if (slot >= records_.size()) return std::nullopt;
    const Records& r = records_[slot];
    auto it = std::lower_bound(r.begin(), r.end(), from, by_frame);
    while (it != r.end() && (it->contradicted || it->vouched)) ++it;
    if (it == r.end()) return std::nullopt;
    return it->frame;
}

std::optional<std::uint32_t> InputAuthority::first_unverified(std::uint32_t from) const {
    std::optional<std::uint32_t> first;
    for (std::size_t s = 0; s < records_.size(); ++s) {
        const auto f = first_unverified_of(static_cast<PlayerId>(s), from);
        if (f && (!first || *f < *first)) first = f;
    }
    return first;
}

void InputAuthority::forget_before(PlayerId slot, std::uint32_t frame) {
    if (slot >= records_.size()) return;
    Records& r = records_[slot];
    while (!r.empty() && r.front().frame < frame) r.pop_front();
}

void InputAuthority::reset_slot(PlayerId slot) {
    if (slot < records_.size()) records_[slot].clear();
}

void InputAuthority::reset_all() {
    for (auto& r : records_) r.clear();
}

}  // namespace lockroll::rollback

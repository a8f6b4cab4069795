#include "rollback/confirm_floors.h"

#include <algorithm>
#include <array>
#include <limits>

namespace lockroll::rollback {

// A peer that becomes live again (a joiner) counts from its own acks on; floors never move back
// (Sync keeps the highest), and what it lacks from before the floor comes with its snapshot.
// A spectator's ack is clamped: a spectator whose process still talks but no longer steps (a
// hung game loop) acknowledged nothing new, and left unbounded its ack filled our queue and
// stopped every player for good. Between the session's ticks (which cut such a spectator
// loose) the clamp alone keeps the floor within reach.
std::uint32_t resend_floor(std::span<const PeerLink> links, const LivePeer& live, std::uint32_t sent,
                           std::uint32_t input_capacity) {
    const std::uint32_t bound = spectator_lag_bound(input_capacity);
    const std::uint32_t spectator_lowest = sent > bound ? sent - bound : 0;
    std::uint32_t floor = std::numeric_limits<std::uint32_t>::max();
    for (std::size_t p = 0; p < links.size(); ++p) {
        if (!live(static_cast<PlayerId>(p))) continue;
        const PeerLink& l = links[p];
        floor = std::min(floor, l.role == Role::Spectator ? std::max(l.remote_ack, spectator_lowest) : l.remote_ack);
    }
    return floor;
}

// Only once it reported our stream: a spectator just welcomed by a peer that did not serve its
// snapshot has acknowledged nothing yet (ack 0), which is no lag of its own.
bool spectator_lags(const PeerLink& link, PlayerId me, std::uint32_t sent, std::uint32_t input_capacity) {
    if (link.role != Role::Spectator || me >= link.has_count.size() || !link.has_count[me]) return false;
    return sent > link.remote_ack && sent - link.remote_ack > spectator_lag_bound(input_capacity);
}

// Never more than half the ring, so a peer that stops acknowledging cannot stall us: it is then
// beyond relaying and must fetch a snapshot.
std::uint32_t keep_floor(PlayerId slot, std::span<const PeerLink> links, const LivePeer& live, std::uint64_t now_us,
                         std::uint32_t confirmed, std::uint32_t input_capacity) {
    std::uint32_t keep = std::numeric_limits<std::uint32_t>::max();
    for (std::size_t p = 0; p < links.size(); ++p) {
        const auto pid = static_cast<PlayerId>(p);
        const PeerLink& l = links[p];
        if (!live(pid)) continue;
        if (l.pin_from && now_us <= l.pin_until_us) keep = std::min(keep, *l.pin_from);
        if (pid != slot && l.has_count[slot]) keep = std::min(keep, l.counts[slot]);
    }
    const std::uint32_t lowest = confirmed > input_capacity / 2 ? confirmed - input_capacity / 2 : 0;
    return std::max(keep, lowest);
}

std::uint32_t held_of_ours(const PeerLink& link, std::span<const PlayerId> guests) {
    std::uint32_t h = link.remote_ack;
    for (const PlayerId g : guests) h = std::min(h, link.has_count[g] ? link.counts[g] : 0u);  // they travel as blocks
    return h;
}

// Frame n is stepped from the inputs of frames before n, and ours among them must be held by a
// majority of the view (this session included; the others' acks say what they hold). So if that
// majority drops us while we cannot hear it (a partition), the neutral input it agrees on for our
// slot starts after every frame we confirmed, and nothing we confirmed can differ from what it
// confirmed. Once we lose the majority, confirmation stops there. A relayed input of a running
// slot waits for its owner's own copy (which wins if it differs), as long as the saved states
// allow: never so far back that the state of the next frame to confirm is no longer saved.
std::uint32_t confirm_limit(const ConfirmBounds& b, std::span<const std::uint32_t> held) {
    if (b.others <= 0) return b.confirmable;
    std::uint32_t majority_holds = 0;
    const auto need = static_cast<std::size_t>(b.others);
    if (held.size() >= need) {
        std::array<std::uint32_t, kMaxPlayers> sorted{};
        const std::size_t n = std::min(held.size(), sorted.size());
        std::copy_n(held.begin(), n, sorted.begin());
        std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(need - 1),
                         sorted.begin() + static_cast<std::ptrdiff_t>(n), std::greater<>());
        majority_holds = sorted[need - 1];
    }
    const std::uint32_t oldest = b.frame > b.saved_span ? b.frame - b.saved_span : 0;
    return std::min(b.confirmable, std::max(std::min(majority_holds, b.unverified), oldest));
}

}  // namespace lockroll::rollback

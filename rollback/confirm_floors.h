// ConfirmFloors: the bounds a P2P session's confirmation and memory keep to (issue 21). Which
// frames it may confirm (a majority of the view must hold our inputs first), how far back our
// own stream is kept (until every live peer acknowledged it), and how far back the other streams
// are kept (for a peer we may relay to, and for a snapshot being served). SessionImpl computes
// them every tick from its links and applies them to Sync; these are the rules alone.
//
// Contract
//  - Pure functions over values: the per-peer links (acks, the counts their tables reported, a
//    served snapshot's pin) and which peers are live, as the session passes them. No clock
//    (now_us comes in), nothing changed.
//  - resend_floor(): the lowest ack among live peers; with no live peer, "no limit" (max): acks
//    stop when nobody else is left, so a floor pinned to a frame would never move again and the
//    lone survivor's queue would fill up. A spectator's ack holds it at most
//    spectator_lag_bound() behind what we sent: players never wait for a spectator.
//  - spectator_lags(): a live spectator that reported our stream and trails what we sent by more
//    than spectator_lag_bound() (input_capacity - input_capacity / 4: our queue then still has a
//    quarter of the ring, at least the largest input delay, before it would fill). The session
//    cuts it loose: no longer live, so its next message is answered "dropped" and it starts
//    again by a fresh snapshot, as after a timeout.
//  - keep_floor(): for a slot's stream, the lowest count a live peer other than its player
//    reported of it, and the pin of a snapshot served to a live peer until it lapses; never
//    further back than half the input ring behind confirmation.
//  - held_of_ours(): the first of our inputs a peer lacks, over our own stream (its ack) and our
//    guests' (the counts its table reported; none reported: it holds none).
//  - confirm_limit(): at most Sync's confirmable frame; without a majority of others to wait for
//    (a spectator, PlayOnAlone), exactly that. Else the frame the `others`-th highest of the live
//    player peers' holdings reaches (0 with fewer than `others` of them), held further back by a
//    relayed input still unverified -- but never behind the oldest frame whose state is saved.
#pragma once

#include <cstdint>
#include <functional>
#include <span>

#include "rollback/peer_link.h"
#include "rollback/session.h"

namespace lockroll::rollback {

using LivePeer = std::function<bool(PlayerId)>;  // a welcomed, healthy, running slot or spectator

// How far a spectator's ack may trail `sent` (the count of our own stream) and still hold it.
constexpr std::uint32_t spectator_lag_bound(std::uint32_t input_capacity) {
    return input_capacity - input_capacity / 4;
}

// The first of our own inputs some live peer has not acknowledged: kept for resending. `sent`:
// our own stream's count.
std::uint32_t resend_floor(std::span<const PeerLink> links, const LivePeer& live, std::uint32_t sent,
                           std::uint32_t input_capacity);

// `me`'s spectator `link` (live) trails `sent` by more than spectator_lag_bound(): cut it loose.
bool spectator_lags(const PeerLink& link, PlayerId me, std::uint32_t sent, std::uint32_t input_capacity);

// The first input of `slot`'s stream still kept (not ours: resend_floor is).
std::uint32_t keep_floor(PlayerId slot, std::span<const PeerLink> links, const LivePeer& live, std::uint64_t now_us,
                         std::uint32_t confirmed, std::uint32_t input_capacity);

// The first of our inputs (own stream and the guests' we author) that `link`'s peer lacks.
std::uint32_t held_of_ours(const PeerLink& link, std::span<const PlayerId> guests);

struct ConfirmBounds {
    std::uint32_t confirmable = 0;  // Sync::confirmable_frame(): every running slot's input known
    std::uint32_t frame = 0;        // the frame being shown
    // The first frame resting on a relayed input its owner has not sent itself; confirmable if none.
    std::uint32_t unverified = 0;
    // How far back states are saved: prediction window + half the evidence frames.
    std::uint32_t saved_span = 0;
    int others = 0;  // the other processes a majority needs (majority_size() - 1); <= 0: none
};

// The newest frame the session may confirm. `held`: held_of_ours() of each live player peer.
std::uint32_t confirm_limit(const ConfirmBounds& b, std::span<const std::uint32_t> held);

}  // namespace lockroll::rollback

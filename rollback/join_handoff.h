// JoinHandoff: a running P2P player's decisions about a snapshot request (the providing side of
// a join, a spectator's start or a desync recovery) -- who may be served at all, which offer goes
// out, and for a join the handoff of the slot to the new process -- and, on the newcomer's side,
// the view an offer carries once its snapshot is loaded. What a served request costs (a young
// offer again, a recovery packed at most once a second, whose chunks) is SnapshotServer's
// (rollback/snapshot_server.h); the newcomer's fetch and vetting are SnapshotFetch's. The session
// wires messages to it and carries out its effects (JoinEffects): sending, events, the resend
// floor, the detector.
//
// Contract
//  - A request is a claim of a few bytes that may cost a whole state: only a running player
//    serves. A recovery only to a running player this session has seen desynced, and only with
//    recoveries on (else counted ignored); a join only from a slot beyond the view whose neutral
//    input this session writes (it owns the drop), and not before its lapsed handoff's backoff
//    ends; a spectator's start only from a peer that is not a slot. Refused joins and
//    spectators are silent. A young offer to the same peer goes again, while our view is the one
//    it carries, before any of that is looked at (SnapshotServer::consider).
//  - A join picks the handoff frame no earlier than handoff_target (far enough ahead that the
//    joiner's first input reaches everyone before they need it), writes the slot's neutral input
//    up to it (a full queue: not now, nothing else changes), and hands the slot to the next
//    epoch with a fresh link that counts as welcomed and heard. A join of a slot we handed over
//    whose stream has not started here (and that we do not vote gone) is that handoff served
//    again: the same epoch and handoff frame, our current frame's state and view, no new
//    `joined`, the link left as it is.
//  - The offer carries our confirmed frame's state with every stream, and our view; what the
//    newcomer will ask for next is pinned for 30 s, and a joiner or spectator counts as holding
//    our stream up to now (it gets the rest with the snapshot).
//  - A chunk request: only of a transfer offered to that peer (else counted ignored), an index
//    past the blob is malformed, at most kMaxChunksPerPoll per peer between polls.
//  - Network input never asserts. No clock (now_us comes in), no sim/ types.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "rollback/control_messages.h"
#include "rollback/membership.h"
#include "rollback/peer_link.h"
#include "rollback/session.h"
#include "rollback/slot_view.h"
#include "rollback/snapshot_server.h"

namespace lockroll::rollback {

class Sync;

// Chunks one peer may pull between two polls.
inline constexpr int kMaxChunksPerPoll = 64;

// The session state a snapshot request reads and changes, borrowed for one request.
struct JoinState {
    const SessionConfig& config;
    Membership& membership;
    Sync& sync;
    SnapshotServer& server;
    std::span<PeerLink> links;          // per peer id (slots, then spectators)
    std::span<SlotView> slots;
    std::span<PeerStats> peer_stats;    // stats().peers, per peer id
    std::span<int> replies_this_poll;   // per peer id: chunks served since the last poll
    bool running = false;               // our phase is Running
};

// What the session does for a served request.
class JoinEffects {
public:
    virtual void send(PlayerId to, std::vector<std::uint8_t> bytes) = 0;
    virtual void malformed(PlayerId from, const char* why) = 0;
    // Our confirmed checksums of some frame differed from the peer's.
    virtual bool desynced(PlayerId peer) const = 0;
    // The earliest handoff frame for a joiner at `slot` (our target frame plus the lead its
    // first input needs to reach everyone).
    virtual std::uint32_t handoff_target(PlayerId slot) const = 0;
    // `slot` was handed to a new process from frame `handoff`, with a snapshot of `frame`.
    virtual void joined(PlayerId slot, std::uint32_t handoff, std::uint32_t frame, std::uint64_t now_us) = 0;
    virtual void spectator_joined(PlayerId peer, std::uint32_t frame, std::uint64_t now_us) = 0;
    // A peer's ack of our stream changed.
    virtual void acked() = 0;

protected:
    ~JoinEffects() = default;
};

class JoinHandoff {
public:
    JoinHandoff(const JoinState& s, JoinEffects& fx) : s_(s), fx_(fx) {}

    // A decoded snapshot request from a welcomed peer: a chunk, or an offer.
    void request(PlayerId from, const SnapshotRequestMessage& m, std::uint64_t now_us);

    // The newcomer's side: the offer of `from` was loaded. Its slot table becomes our view (a
    // newcomer has handed nothing over; a slot beyond the view has its neutral input told), and
    // every link starts its liveness afresh.
    static void take_view(const SnapshotOfferMessage& offer, Membership& membership, std::span<SlotView> slots,
                          std::span<PeerLink> links, std::uint64_t now_us);

private:
    void chunk(PlayerId from, const SnapshotRequestMessage& m);
    // A join: the handoff frame, or none (refused, or the queue is full: not now).
    bool hand_over(PlayerId from, std::uint32_t frame, std::uint64_t now_us, std::uint32_t& handoff);
    // A join of a running slot: our own pending handoff's frame, offered again, or none.
    bool serve_again(PlayerId from, std::uint32_t& handoff) const;
    // Our view as an offer carries it: every slot's state and epoch.
    std::vector<SlotEntry> view_table() const;
    void offer(PlayerId from, TransferReason reason, std::uint32_t frame, std::uint32_t handoff, std::uint64_t now_us);
    bool is_slot(PlayerId p) const { return p < static_cast<PlayerId>(s_.config.players); }
    std::uint32_t count_of(PlayerId slot) const;
    void ignore(PlayerId from) { ++s_.peer_stats[from].ignored_packets; }

    JoinState s_;
    JoinEffects& fx_;
};

}  // namespace lockroll::rollback

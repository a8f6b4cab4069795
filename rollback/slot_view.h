// SlotView: what a P2P session does about one slot beyond the view (Membership holds state and
// epoch): whether it writes the slot's neutral inputs, handed it over, voted it gone, and the
// backoff of handoffs that lapsed. One per slot, owned by SessionImpl (rollback/session_impl.h).
//
// Contract
//  - new_epoch(): the slot changed hands (dropped, adopted from a peer's table, handed over, or
//    loaded from a snapshot): every per-epoch flag starts over. The handoff backoff (lapses,
//    next_handoff_us) and the handoff frame outlive epochs: they belong to the slot, not to the
//    process that played it.
#pragma once

#include <cstdint>

namespace lockroll::rollback {

struct SlotView {
    bool authoring = false;           // owner: writing its neutral inputs
    bool neutral_reported = false;    // NeutralFrom event fired for this epoch
    std::uint32_t handoff = 0;        // Running after a join: its own inputs start here
    bool handed_off_by_me = false;
    bool kick_vote = false;           // disconnect_player: the local vote stays until the drop
    // A handed-over slot whose own stream has not started (its newest input is the owner's
    // neutral one): since when, and whether that lasted disconnect_us and we voted it gone
    // (a lapsed handoff: the vote stays until the drop, like a kick; check_silence).
    std::uint64_t pending_since_us = 0;
    bool lapsed = false;
    // Owner: handoffs of this slot that lapsed in a row, and no new one before this time
    // (disconnect_us << lapses, at most 8x: a joiner that never loads stalls the match for
    // at most disconnect_us per attempt, and ever more rarely).
    int lapses = 0;
    std::uint64_t next_handoff_us = 0;

    void new_epoch() {
        kick_vote = false;
        lapsed = false;
        pending_since_us = 0;
        authoring = false;
        neutral_reported = false;
        handed_off_by_me = false;
    }
};

}  // namespace lockroll::rollback

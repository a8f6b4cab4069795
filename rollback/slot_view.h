// SlotView: what a P2P session does about one slot beyond the view (Membership holds state and
// epoch): whether it writes the slot's neutral inputs, handed it over, voted it gone, and the
// backoff of handoffs that lapsed. One per slot, owned by SessionImpl (rollback/session_impl.h).
//
// Contract
//  - new_epoch(): the slot changed hands (dropped, adopted from a peer's table, handed over, or
//    loaded from a snapshot): every per-epoch flag starts over. The handoff backoff (lapses,
//    next_handoff_us) and the handoff frame outlive epochs: they belong to the slot, not to the
//    process that played it.
//  - dropped(): a new epoch, and if the slot's handoff had lapsed, the next handoff waits 2, 4,
//    then 8 x disconnect_us, unless the handoff was orphaned (its maker left first: the joiner
//    was not at fault); watch_handoff() says when a handoff lapses (true once: vote it gone).
#pragma once

#include <cstdint>

#include "rollback/input_queue.h"
#include "rollback/protocol.h"
#include "rollback/restart_claim.h"

namespace lockroll::rollback {

// The slot's own process plays: we hold an input of its stream, and the newest is its own, not
// the owner's neutral one (flagged absent) written up to a handoff or from a drop on.
inline bool stream_started(const InputQueue& q) { return q.confirmed_count() > 0 && !q.last_absent(); }

struct SlotView {
    bool authoring = false;           // owner: writing its neutral inputs
    bool neutral_reported = false;    // NeutralFrom event fired for this epoch
    std::uint32_t handoff = 0;        // Running after a join: its own inputs start here
    bool handed_off_by_me = false;
    bool kick_vote = false;           // disconnect_player: the local vote stays until the drop
    // MembershipChanges::claim_restart: our vote came from a hello of another process of the slot
    // (a player's hello: "restarted", a joiner's: "rejoining"), not from its silence.
    bool restart_vote = false;
    bool restart_by_player = false;
    // Hellos claiming the slot's process restarted, before the claim counts (rollback/
    // restart_claim.h): noted when it begins, void once the old process is heard again.
    RestartClaim restart_claim;
    // A handed-over slot whose own stream has not started (its newest input is the owner's
    // neutral one): since when, and whether that lasted disconnect_us (a lapsed handoff: the
    // drop's reason, and the next handoff backs off). lapse_vote: our vote from that lapse
    // stands; hearing the joiner does not withdraw it, its stream starting here does.
    std::uint64_t pending_since_us = 0;
    bool lapsed = false;
    bool lapse_vote = false;
    // Who made the handoff, as far as this process can tell: itself (JoinHandoff::hand_over), or
    // the owner of the view it held when a peer's table told it (the lowest running slot, which
    // alone hands slots over: MembershipChanges::adopt_slot); kNoSlot when not handed over.
    PlayerId maker = kNoSlot;
    // The maker left the view while the joiner's stream had not started (MembershipChanges::
    // drop_slot). Only the maker serves its handoff and nothing else can end it, so waiting out
    // disconnect_us only stalls everyone: the handoff lapses at once, and the slot's next
    // handoff does not back off (a joiner that never got its snapshot is not one that cannot
    // load). Issue 21: a joiner whose owner died waited 2 x disconnect_us more for that backoff.
    bool orphaned = false;
    // Owner: handoffs of this slot that lapsed in a row, and no new one before this time
    // (disconnect_us << lapses, at most 8x: a joiner that never loads stalls the match for
    // at most disconnect_us per attempt, and ever more rarely).
    int lapses = 0;
    std::uint64_t next_handoff_us = 0;

    void new_epoch() {
        kick_vote = false;
        restart_vote = false;
        restart_by_player = false;
        restart_claim.clear();
        lapsed = false;
        lapse_vote = false;
        pending_since_us = 0;
        maker = kNoSlot;
        orphaned = false;
        authoring = false;
        neutral_reported = false;
        handed_off_by_me = false;
    }
    // The slot left the view (its epoch ended); a lapsed handoff backs off the next one, an
    // orphaned one does not.
    void dropped(std::uint64_t now_us, std::uint64_t disconnect_us);

    // A joiner that cannot load (its snapshot refused again and again) keeps talking, so silence
    // never drops it, yet the match stalls at its handoff frame for inputs that never come: the
    // 16-minute soak froze for good (issue 21). The contract for a running slot that stalls the
    // others is a stall of at most disconnect_us (docs/sessions.md, "Cost"); so a handed-over slot
    // whose own stream has not started -- the newest input we hold of it is still the owner's
    // neutral one, flagged absent -- for disconnect_us after we first need its input is voted gone
    // here, and the vote is not withdrawn by hearing it (it is heard; it does not play). A majority
    // drops it as usual, the slot stays neutral, and the joiner may ask again: the owner hands the
    // slot over again only after 2, 4, then 8 x disconnect_us (dropped), so one that never loads
    // costs the others a stall of disconnect_us per attempt, ever more rarely. Its stream starting
    // resets the backoff, and withdraws our vote if the drop has not come yet: a joiner that
    // loaded just past the deadline plays, and kept, the vote dropped it all the same and sent it
    // back to fetch a snapshot, which at five players took longer than disconnect_us again.
    // An orphaned handoff (its maker left) lapses as soon as it is pending, without waiting
    // disconnect_us: nobody can serve it any more. A joiner that had loaded before its maker died
    // sent its input for the handoff frame before we needed it (the frame's lead is chosen so:
    // JoinHandoff::hand_over), so its stream has started here and it is not pending; one whose
    // input comes after our vote but before the drop plays, and the vote is withdrawn (Started).
    // Called per tick for every other process's slot: running, its stream (q) and our frame.
    enum class Watch {
        Nothing,
        Lapsed,   // the handoff lapses now: the caller votes the slot gone
        Started,  // its stream started after it lapsed here: the caller withdraws that vote
    };
    Watch watch_handoff(bool running, const InputQueue& q, std::uint32_t frame, std::uint64_t now_us,
                        std::uint64_t disconnect_us);
};

}  // namespace lockroll::rollback

// AuthoredStreams: the streams a P2P session writes besides its own local one (issue 21). The
// owner (the lowest running slot) writes every non-running slot's neutral input, flagged absent,
// so the frame loop never waits for a slot nobody plays; a process that hosts guest slots
// (config.slot_hosts) writes their inputs as it writes its own. One per session, owned by
// SessionImpl (rollback/session_impl.h); the peers get these streams as blocks (stream_relay.h).
//
// Contract
//  - Borrows the session's config, view, per-slot SlotViews and per-peer links (all outlive it);
//    reads and writes the streams and emits through AuthoringEffects (SessionImpl's Sync and
//    event queue; a test fakes them). No clock (now_us comes in); slots and peers are ids.
//  - author_absent_streams(): only the owner, never a spectator. For a slot just dropped it first
//    waits until every live player peer's table reports the drop applied (the slot's epoch and
//    state as ours, not flagged as a vote: a voter still takes the slot's inputs while it runs
//    there) with a count of the slot's stream no greater than ours (peers relay what we lack):
//    then the neutral inputs start right after the last real input anyone received, and nobody
//    has confirmed anything else. From then on (SlotView::authoring, until the slot's next epoch)
//    the slot's stream is written up to `target` inclusive, and `neutral_from` is emitted once
//    per epoch with the first neutral frame. A write not Stored stops that slot until next time.
//  - author_guest_streams(): each running guest (local_slots after the first) follows the local
//    stream frame for frame up to its count: the gap a longer input delay opens repeats the
//    guest's last input (neutral if none), as the local stream does, and the last frame takes
//    the guest's given input.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rollback/events.h"
#include "rollback/input_queue.h"
#include "rollback/membership.h"
#include "rollback/part_effects.h"
#include "rollback/peer_link.h"
#include "rollback/session.h"
#include "rollback/slot_view.h"

namespace lockroll::rollback {

// What writing a stream does in the rest of the session, beyond the hooks every part has
// (PartEffects: emit, live_peer, stream). SessionImpl implements it.
class AuthoringEffects : public virtual PartEffects {
public:
    // A confirmed input of the slot's stream (Sync::add_remote_input: a misprediction rolls back).
    virtual InputQueue::Add write(PlayerId slot, std::uint32_t frame, std::span<const std::uint8_t> input,
                                  bool absent) = 0;

protected:
    ~AuthoringEffects() = default;
};

class AuthoredStreams {
public:
    AuthoredStreams(const SessionConfig& config, const Membership& view, std::vector<SlotView>& slots,
                    const std::vector<PeerLink>& links, AuthoringEffects& effects);

    // target: the frame our own next input goes to (frame + input delay).
    void author_absent_streams(std::uint32_t target, std::uint64_t now_us);
    // local_slots: SessionImpl::local_slots() (ours first, then our guests); inputs: one per guest.
    void author_guest_streams(std::span<const PlayerId> local_slots, std::span<const std::uint8_t> inputs);
    // The lowest running slot, which writes the neutral inputs.
    std::optional<PlayerId> owner() const;

private:
    bool ready_to_author(PlayerId slot) const;
    std::uint32_t count_of(PlayerId slot) const { return effects_.stream(slot).confirmed_count(); }

    const SessionConfig& config_;
    const Membership& view_;
    std::vector<SlotView>& slots_;
    const std::vector<PeerLink>& links_;
    AuthoringEffects& effects_;
    std::vector<std::uint8_t> scratch_;  // a guest's input being written
};

}  // namespace lockroll::rollback

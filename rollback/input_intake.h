// InputIntake: what a peer's input message changes in a P2P session, once unwrap_input
// (rollback/input_frames.h) has unwrapped and checked its frames: our acks, the sender's inputs
// into Sync, the owner's copy settling relayed frames (InputAuthority), the sender's slot table
// as counts and votes, and the blocks of other streams it relays, which only fill gaps.
// SessionImpl::receive_impl hands it each decoded input message; what the session itself does
// about membership (adopting a slot's new epoch, counting a vote, settling the view) and about a
// malformed message stays the session's, reached through IntakeEffects.
//
// Contract
//  - Network input never asserts: a message whose frames do not unwrap changes nothing and is
//    malformed; so is an input that rewrites a confirmed one (the sender's own, or its guest's,
//    where no relay's copy explains it) and a relayed input that contradicts a confirmed one of
//    a slot that does not run.
//  - The owner wins: its copy of a relayed frame verifies it (equal) or replaces it where no
//    confirmed frame rests on it yet; the relay is then counted (relay_disagreements) and its
//    relayed blocks ignored from then on. A relayed block that contradicts the owner's own input
//    is counted and ignored, never a malformed message; one that contradicts another relay's
//    claim is remembered, and counted the same way once the owner's copy verifies that claim.
//  - A spectator's table reports counts and never votes; a player's entry about itself or its
//    guests says nothing new; nobody but this session's process hands over this session's slots.
//  - Reads and writes the session through IntakeState, borrowed for one message; no clock (now_us
//    comes in), no sim/ types. Stops at once when an effect fails the session.
#pragma once

#include <cstdint>
#include <span>

#include "rollback/input_queue.h"
#include "rollback/membership.h"
#include "rollback/peer_link.h"
#include "rollback/protocol.h"
#include "rollback/session.h"
#include "rollback/slot_view.h"

namespace lockroll::rollback {

class InputAuthority;
class Sync;

// The session state a peer's input message changes, borrowed for one message.
struct IntakeState {
    const SessionConfig& config;
    const Membership& membership;
    Sync& sync;
    InputAuthority& authority;
    std::span<PeerLink> links;         // per peer id (slots, then spectators)
    std::span<SlotView> slots;
    std::span<PeerStats> peer_stats;   // stats().peers, per peer id
    std::uint32_t newest_checksum = 0; // our newest confirmed checksum's frame
    std::int64_t advantage_bound = 0;  // FramePacing::advantage_bound: a sender's claim is clipped to it
};

// What the session does for the intake: its membership actions and its bookkeeping.
class IntakeEffects {
public:
    // The sender broke the protocol (counted; too many and its link is in error).
    virtual void malformed(PlayerId from, const char* why) = 0;
    // A peer acknowledged more of our stream.
    virtual void acked() = 0;
    // The sender's table hands `slot` to a new epoch (a join, a drop we missed, a new process).
    virtual void adopt_slot(PlayerId slot, const SlotEntry& e, std::uint64_t now_us) = 0;
    // The sender's vote about a running slot.
    virtual void count_vote(PlayerId voter, PlayerId slot, Vote vote, std::uint8_t epoch) = 0;
    // The sender's agreement report on the next drop (rollback/drop_agreement.h).
    virtual void heard_agreement(PlayerId voter, const AgreementReport& r) = 0;
    // The sender's table states a drop it applied (an entry not voted) of running `slot`.
    virtual void heard_drop(PlayerId voter, PlayerId slot, std::uint8_t epoch) = 0;
    // After a table: the votes may have settled a slot.
    virtual void settle_membership(std::uint64_t now_us) = 0;
    // The sender's confirmed checksum of one frame.
    virtual void remote_checksum(PlayerId from, std::uint32_t frame, std::uint64_t checksum) = 0;
    // The first absent input of a slot beyond the view in this epoch: the agreed frame.
    virtual void neutral_from(PlayerId slot, std::uint32_t frame) = 0;
    virtual bool failed() const = 0;

protected:
    ~IntakeEffects() = default;
};

class InputIntake {
public:
    InputIntake(const IntakeState& s, IntakeEffects& fx) : s_(s), fx_(fx) {}

    // The decoded input message m from peer `from`.
    void apply(PlayerId from, const InputMessage& m, std::uint64_t now_us);

    // The owner's own input of `slot` at frame f came in (added: what the queue made of it).
    // False only when it contradicts an input nobody relayed: the owner rewrote its own past.
    bool owner_copy(PlayerId slot, std::uint32_t f, std::span<const std::uint8_t> input, InputQueue::Add added);

private:
    void apply_slot_table(PlayerId from, const InputMessage& m, std::uint64_t now_us);
    void apply_blocks(PlayerId from, const InputMessage& m);
    bool relayed_block(PlayerId from, const StreamBlock& b, std::uint32_t first);
    bool is_slot(PlayerId p) const { return p < static_cast<PlayerId>(s_.config.players); }
    PlayerId host_of(PlayerId slot) const;
    bool mine(PlayerId slot) const;  // ours or our guest's, and we play
    std::uint32_t count_of(PlayerId slot) const;

    IntakeState s_;
    IntakeEffects& fx_;
};

}  // namespace lockroll::rollback

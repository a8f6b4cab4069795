// StreamRelay: what a P2P session's input message to one peer carries beyond its own inputs
// (issue 21): the slot table -- to a player our vote about every slot, to a spectator our view,
// with our count of every stream -- and blocks of other slots' streams the receiver lacks and
// will get from nobody else soon. SessionImpl::poll_impl asks it, per peer, whether this message
// carries the table and fills it; nothing is sent from here.
//
// Contract
//  - Reads the session through a StreamView borrowed for the call (one poll): no state of its
//    own, no clock (now_us comes in), no sim/ types.
//  - extension_needed(): always for a spectator, a joiner catching up, a spectator peer, guests,
//    a slot that does not run, a vote that someone is gone, a handoff of ours. Once every slot
//    simply runs: when what we tell that peer changed (PeerLink::table_due: kTableCopies copies
//    spread out, then a refresh every table_refresh_us()), and with three or more players on
//    time-sync messages while we lag on a stream (lags_on_a_stream) or the peer's fresh counts
//    say it lags by more than relay_lag.
//  - fill_extension(): the table always; then (players only) blocks, within `budget` bytes
//    (blocks shrink to fit, at most kMaxStreamBlocks): non-running slots, our guests, a joiner's
//    stream up to our handoff, everything for a spectator, and any stream on which the peer's
//    fresh counts lag by more than relay_lag. Never the peer's own stream or ours, and of a
//    running slot only what its owner's own stream delivered (InputAuthority), never another
//    relay's claim.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "rollback/input_queue.h"
#include "rollback/membership.h"
#include "rollback/peer_link.h"
#include "rollback/drop_agreement.h"
#include "rollback/protocol.h"
#include "rollback/session.h"
#include "rollback/slot_hosts.h"
#include "rollback/slot_view.h"

namespace lockroll::rollback {

class InputAuthority;

// A change of the table goes out in this many copies (PeerLink::table_due spreads them over ~1 s).
inline constexpr int kTableCopies = 8;

// The session state StreamRelay reads, borrowed for one call.
struct StreamView {
    const SessionConfig& config;
    const Membership& membership;
    std::span<const InputQueue> queues;  // every slot's stream (Sync's)
    const InputAuthority& authority;
    std::span<const SlotView> slots;
    std::span<const PeerLink> links;     // per peer id (slots, then spectators)
    std::uint32_t confirmed_frame = 0;   // owner_count() checks relayed inputs from a little before it
    int input_delay = 0;
    bool joining = false;                // a joiner catching up: its table always rides
    // The agreement on the next drop (rollback/drop_agreement.h): rides to players with the
    // table while a ballot is in play.
    const DropAgreement* agreement = nullptr;
};

class StreamRelay {
public:
    explicit StreamRelay(const StreamView& v);

    // What our table says about slot s to peer `to`.
    SlotEntry table_entry(PlayerId to, PlayerId s) const;
    // Every slot's (state << 8 | epoch) as told to `to`: what PeerLink compares for a change.
    void table_entries_for(PlayerId to, std::vector<std::uint16_t>& out) const;
    // We lag on some running stream: our counts should reach the peers, which relay.
    bool lags_on_a_stream() const;
    // entries: table_entries_for(to); lagging: lags_on_a_stream() (once per poll).
    bool extension_needed(PlayerId to, const std::vector<std::uint16_t>& entries, std::uint64_t now_us,
                          bool lagging) const;
    void fill_extension(PlayerId to, InputMessage& m, std::size_t budget, std::uint64_t now_us) const;
    // Our agreement report goes to `to` on this message (fill_extension).
    bool agreement_rides(PlayerId to) const;
    // What we tell slot s's owner we hold of its stream (ack and table count): up to the first
    // input a relay filled in that the owner has not verified yet, confirmed or not (up to a
    // quarter of the input ring behind confirmation).
    std::uint32_t owner_count(PlayerId s) const;
    // How often a changed table is repeated once its copies went out (0: never).
    std::uint64_t table_refresh_us() const;

private:
    bool is_slot(PlayerId p) const { return p < static_cast<PlayerId>(v_.config.players); }
    PlayerId host_of(PlayerId s) const { return lockroll::rollback::host_of(v_.config, s); }
    bool my_guest(PlayerId p) const {
        return v_.config.role != Role::Spectator && host_of(p) != p && host_of(p) == v_.config.local_player;
    }
    std::uint32_t count_of(PlayerId s) const { return v_.queues[s].confirmed_count(); }
    bool counts_fresh(const PeerLink& link, std::uint64_t now_us) const;
    bool relay_wanted(PlayerId to, std::uint64_t now_us) const;

    StreamView v_;
    bool any_guest_ = false;
    bool any_slot_not_running_ = false;
};

}  // namespace lockroll::rollback

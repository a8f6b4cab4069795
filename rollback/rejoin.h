// Rejoining after a drop (issue 21, "when the network heals it rejoins the majority's view by
// snapshot, without pausing anyone"): a process whose slot the others dropped -- the minority of
// a partition that has since healed, or a player restarted while its old process still counted
// as running -- comes back into that same slot as a joiner, by a snapshot vetted by the
// majority's confirmed checksum (rollback/snapshot_vetting.h), and catches up while nobody
// waits for it.
//
// Contract
//  - The decision is this file's, one rule for every caller: net::PeerRunner (so `lockroll
//    peer`, net::NetSession and the C ABI) and the virtual-time match (harness/match) call
//    Session::can_rejoin() / restart_as_joiner(), which ask can_rejoin() below; none decides it
//    again.
//  - can_rejoin(c, kicked): the others dropped this session (kicked: it emitted `kicked`, and has
//    failed) and its process can come back: a player or a joiner into its slot, as a joiner; a
//    spectator (the players stopped serving it: cut off from every one of them past
//    disconnect_us) as a spectator again, by a fresh snapshot. Not a process that hosts other
//    slots: rejoin_refusal() says why. Any other failure (refused, desync beyond the
//    recoveries, the game threw) is no drop.
//  - rejoin_refusal(c): why a dropped process of this config cannot come back (empty: it can),
//    for its outcome: one that hosts guest slots (SessionConfig::slot_hosts) cannot, since a
//    joiner cannot host guests yet (each guest would need its own handoff and stream start).
//  - drop_failure(c): what a session of this config fails with when the others dropped it
//    (after its `kicked`): that, and rejoin_refusal()'s reason when there is one, so a run's
//    outcome says why no rejoin followed.
//  - rejoin_config(c, scene_checksum): the config it starts again with: everything as it was
//    (slot, match id, delays, window, timeouts, the two-player rule), but role Joiner (a
//    spectator stays Spectator), the handshake on (a newcomer needs it, also where the match
//    runs without one), the match's scene checksum (the hello carries it, and the simulation has
//    moved on from the state it was taken from), and a new incarnation (0: the session derives
//    one from its first hello's time), so the others tell the new process from the one they
//    dropped.
//  - SessionImpl::continue_from(before): what the successor keeps of the session it replaces,
//    so that one process's figures and settings go on: its counters (stats(): ticks, frames,
//    rollbacks, bytes, ... summed; per-peer counters too; not the state fields -- round trips,
//    errors, advantage -- which the new links measure again), its last frame
//    (set_last_frame) and its prediction window (set_prediction_window). Not kept: injected
//    faults and chunk damage (test hooks), undrained events.
//  - joiner_input(...): where a (re)joiner's own input goes each tick once it runs (docs/sessions.md,
//    Join step 5), the one rule SessionImpl follows. Its stream starts at the handoff frame H,
//    ahead of the frame it loaded, and it sends one input per tick from the end of its stream
//    (the match's pace, while its own frame catches up) -- but never more than `lead` frames
//    beyond its frame + delay: the lead the owner gave H (the worst round trip in frames + 2,
//    so an input reaches everyone before they need it), measured again by the joiner. Past it,
//    nothing new until its frame + delay comes within it. Per tick alone is not the match's
//    pace: the match steps slower than the tick rate whenever it stalls or waits for time sync,
//    and a joiner that kept one input per tick until its frame + delay met its stream (the old
//    rule; with H's lead that moment might never come) ran its stream ahead of every frame
//    played by ~6 frames a second, ~600 after a minute and a kill's stall (the 16-minute soak:
//    a provider's next snapshot then carried more than input_capacity / 2 inputs of that
//    stream and the next joiner refused it).
//  - Pure: no clock, no I/O.
#pragma once

#include <cstdint>
#include <string>

#include "rollback/session.h"  // SessionConfig
#include "rollback/session_types.h"  // SessionStats

namespace lockroll::rollback {

bool can_rejoin(const SessionConfig& c, bool kicked);
std::string rejoin_refusal(const SessionConfig& c);
std::string drop_failure(const SessionConfig& c);
SessionConfig rejoin_config(const SessionConfig& c, std::uint64_t scene_checksum);
// Adds the counters of `before` to `into` (see continue_from above).
void carry_counters(const SessionStats& before, SessionStats& into);

// A joiner's own input this tick (see joiner_input above). `count`: its stream's length (the
// next frame it would send); `local_target`: its frame + input delay; `lead`: how far its stream
// may run ahead of local_target.
struct JoinerInput {
    bool joining = false;         // still pacing by tick, or holding within its lead
    std::uint32_t min_frame = 0;  // Sync::add_local_input's min_frame: no input before it
};
JoinerInput joiner_input(bool joining, std::uint32_t count, std::uint32_t local_target, std::uint32_t lead);

}  // namespace lockroll::rollback

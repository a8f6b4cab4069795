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
//    failed) and its process can play its slot again as a joiner: a player or a joiner, not a
//    spectator, and not a process that hosts other slots (a joiner cannot host guests yet).
//    Any other failure (refused, desync beyond the recoveries, the game threw) is no drop.
//  - rejoin_config(c, scene_checksum): the config it starts again with: everything as it was
//    (slot, match id, delays, window, timeouts, the two-player rule), but role Joiner, the
//    handshake on (a joiner needs it, also where the match runs without one), the match's scene
//    checksum (the hello carries it, and the simulation has moved on from the state it was taken
//    from), and a new incarnation (0: the session derives one from its first hello's time), so
//    the others tell the new process from the one they dropped.
//  - SessionImpl::continue_from(before): what the successor keeps of the session it replaces,
//    so that one process's figures and settings go on: its counters (stats(): ticks, frames,
//    rollbacks, bytes, ... summed; per-peer counters too; not the state fields -- round trips,
//    errors, advantage -- which the new links measure again), its last frame
//    (set_last_frame) and its prediction window (set_prediction_window). Not kept: injected
//    faults and chunk damage (test hooks), undrained events.
//  - Pure: no clock, no I/O.
#pragma once

#include <cstdint>

#include "rollback/session.h"  // SessionConfig
#include "rollback/session_types.h"  // SessionStats

namespace lockroll::rollback {

bool can_rejoin(const SessionConfig& c, bool kicked);
SessionConfig rejoin_config(const SessionConfig& c, std::uint64_t scene_checksum);
// Adds the counters of `before` to `into` (see continue_from above).
void carry_counters(const SessionStats& before, SessionStats& into);

}  // namespace lockroll::rollback

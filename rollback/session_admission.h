// Which hellos a P2P session welcomes, and why it refuses the others: the checks of the
// handshake (docs/sessions.md, "Handshake"), apart from what the session then does about them.
//
// Contract
//  - A pure decision over the hello and what the session knows of its sender (HelloContext):
//    no clock, no I/O, no session state. The session sends the welcome, counts and reports the
//    refusal, rate-limits it, and drops a slot whose process restarted.
//  - The checks go in order and the first that fails decides: protocol version, match id, scene
//    checksum (each refused with both values in `why`), a role that does not fit the sender's
//    peer id, then "retry" for a newcomer while this session does not run yet (it has no
//    snapshot to serve), "disconnected" for a player hello from a slot this session dropped,
//    and "retry" with `restarted` for a joiner hello from another process than the one welcomed
//    for a slot still running in the epoch it was welcomed in (the old process restarted: the
//    session drops it and welcomes the new one once that is agreed). A slot running in a newer
//    epoch than it was welcomed in is the joiner itself, handed over by its owner, and so is a
//    slot this session handed over: both are welcomed. Last, "disconnected" with `restarted`
//    for a player hello from another process than the one welcomed (a nonzero incarnation) for
//    a slot still running: it restarted with its usual settings and must rejoin as a joiner
//    (the session drops the old process first and sends the drop's epoch).
#pragma once

#include <cstdint>
#include <string>

#include "rollback/control_messages.h"
#include "rollback/session_types.h"

namespace lockroll::rollback {

// What the session knows of the sender when its hello arrives.
struct HelloContext {
    std::uint64_t match_id = 0;        // ours
    std::uint64_t scene_checksum = 0;  // ours
    PlayerId from = 0;
    bool from_slot = false;            // `from` is a player slot (else a spectator's id)
    bool running = false;              // this session is past its sync phase
    // About from's link and slot (players):
    bool welcomed = false;             // we welcomed a process for it before
    std::uint64_t incarnation = 0;     // the process we welcomed
    bool slot_running = false;         // its slot runs in our view
    bool welcomed_in_this_epoch = false;  // the slot's epoch is the one we welcomed it in
    bool handed_off_by_me = false;     // this session handed the slot to a joiner
};

struct HelloAdmission {
    Refusal refusal = Refusal::None;
    std::string why;         // what did not fit, for a refusal other than Retry (else empty)
    bool restarted = false;  // the slot's welcomed process restarted: drop it first
};

HelloAdmission admit_hello(const HelloMessage& m, const HelloContext& c);

}  // namespace lockroll::rollback

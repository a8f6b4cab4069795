// Which hellos a P2P session welcomes, and why it refuses the others: the checks of the
// handshake (docs/sessions.md, "Handshake"), apart from what the session then does about them.
//
// Contract
//  - A pure decision over the hello and what the session knows of its sender (HelloContext):
//    no clock, no I/O, no session state. The session sends the welcome, counts and reports the
//    refusal, rate-limits it, and votes gone a slot whose process restarted.
//  - The checks go in order and the first that fails decides: protocol version, match id, scene
//    checksum (each refused with both values in `why`), a role that does not fit the sender's
//    peer id, then "retry" for a newcomer while this session does not run yet (it has no
//    snapshot to serve), "disconnected" for a player hello from a slot this session dropped,
//    and "retry" with `restarted` for a joiner hello from another process than the one welcomed
//    for a slot still running in the epoch it was welcomed in (the old process restarted: the
//    session votes it gone and welcomes the new one once a majority dropped it). A slot running
//    in a newer epoch than it was welcomed in is the joiner itself, handed over by its owner,
//    and so is a slot this session handed over: both are welcomed. Last, "disconnected" with
//    `restarted` for a player hello from another process than the one welcomed (a nonzero
//    incarnation) for a slot still running: it restarted with its usual settings and must
//    rejoin as a joiner (once the old process is dropped: the session answers "retry" until
//    then, and then "disconnected" in the drop's epoch).
//  - A restart is a claim, not a fact (issue 21): anyone can send a hello with a slot's id (ENet
//    ids are not authenticated). Both restart cases hold only while the welcomed process has
//    been silent for at least restart_quiet_us(interrupt_us), half the interruption time: a
//    crashed process is silent, a live one sends every tick, so that is some 20 ticks of loss
//    in a row. Otherwise the hello is refused "retry" with `doubted` and a `why` (the session
//    counts it as a foreign packet and reports it, rate-limited); a genuine restart is let in
//    once its predecessor has been quiet that long, by its next hellos. Even then `restarted`
//    only lets the claim in: it becomes this session's vote once it has stood, the old process
//    unheard, for restart_confirm_us after its first hello (doubted or not; rollback/
//    restart_claim.h, MembershipChanges::claim_restart), and the slot leaves by the majority
//    rule, like a silent one.
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
    std::uint64_t silent_us = 0;       // since the welcomed process was last heard
    std::uint64_t interrupt_us = 0;    // SessionConfig::interrupt_us
};

// How long a slot's welcomed process must have been silent before a hello from another process
// of it counts as a restart (see the contract).
constexpr std::uint64_t restart_quiet_us(std::uint64_t interrupt_us) { return interrupt_us / 2; }

struct HelloAdmission {
    Refusal refusal = Refusal::None;
    std::string why;         // what did not fit, for a refusal other than Retry or a doubted claim (else empty)
    bool restarted = false;  // the slot's welcomed process restarted: vote it gone first
    bool doubted = false;    // a restart claimed while the welcomed process still talks: Retry
};

HelloAdmission admit_hello(const HelloMessage& m, const HelloContext& c);

}  // namespace lockroll::rollback

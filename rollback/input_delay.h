// The one input-delay policy (issue 21): how many frames a local input is held before its frame
// is simulated, from how long it takes to reach the players who need it. The P2P session (its
// sync phase), the relay session (its welcome and every revision) and the harness (auto and
// adaptive) all ask these functions; before, the rule lived as four formulas in three layers.
//
// Contract:
//  - reach_us: the time a local input needs to reach every player who needs it, with whatever
//    margin for jitter the caller measured (peer to peer: half the worst round trip; through the
//    relay server: the round trip to the server, which it crosses on its way to the others,
//    plus twice the jitter).
//  - Lockstep (prediction window 0) covers reach in whole frames plus one frame for tick phase:
//        lockstep = ceil(reach_us * tick_rate / 1e6) + 1            (exact integer arithmetic)
//  - Rollback takes half of that, rounded up: shallower rollbacks for a little input latency.
//        rollback = (lockstep + 1) / 2
//  - Adaptive rollback (a window fixed mid-match) never goes so low that delay + window falls to
//    lockstep's delay or below, or it would stall more than lockstep: max(rollback, lockstep -
//    window + 1).
//  - Every result is 1..kMaxInputDelay; callers clamp further to their queues (input_capacity/4).
//  - Integers only, no clock: tick_rate must be >= 1.
#pragma once

#include <cstdint>

namespace lockroll::rollback {

// The largest input delay any session accepts (frames; one second at 60 Hz).
inline constexpr int kMaxInputDelay = 60;

// Lockstep's delay: reach covered in whole frames, plus one.
int lockstep_input_delay(std::uint64_t reach_us, int tick_rate);

// Rollback's delay: half of lockstep's, rounded up.
int rollback_input_delay(std::uint64_t reach_us, int tick_rate);

// The delay for a session with this prediction window (0: lockstep, else rollback).
int auto_input_delay(int prediction_window, std::uint64_t reach_us, int tick_rate);

// The delay adaptive mode moves to mid-match with this (fixed) prediction window.
int adaptive_input_delay(int prediction_window, std::uint64_t reach_us, int tick_rate);

}  // namespace lockroll::rollback

// The small values a game exchanges with either session (P2P Session, RelaySession) each tick
// and reads from them: the datagram it hands to its transport, what a tick did, the session's
// phase, a slot's state, and the role a process asks for. Installed: the sessions' public
// headers name these, so they live apart from the wire codecs (protocol.h, control_messages.h,
// relay_messages.h), which use the same enums and say which byte values are valid on the wire.
#pragma once

#include <cstdint>
#include <vector>

#include <lockroll/rollback/player_id.h>

namespace lockroll::rollback {

// What a peer asks to be when it says hello (P2P; SessionConfig::role).
enum class Role : std::uint8_t {
    Player = 0,     // a slot present from frame 0
    Joiner = 1,     // a slot joining (or rejoining) a running match by snapshot
    Spectator = 2,  // follows the match, never sends inputs
};

// The same through the relay server (RelaySessionConfig::role).
enum class RelayRole : std::uint8_t { Player = 0, Joiner = 1, Spectator = 2 };

// A player slot's lifecycle state as peers gossip it (docs/sessions.md). Each change bumps the
// slot's epoch; the higher epoch wins, so every peer converges on one table.
enum class SlotState : std::uint8_t {
    Absent = 0,        // nobody plays it yet: its input is the flagged neutral input
    Running = 1,       // its owner process sends its inputs
    Disconnected = 2,  // it was dropped (timeout or kick): flagged neutral input from an agreed frame
};

enum class SessionPhase : std::uint8_t { Synchronizing, Transferring, Running, Failed };
const char* phase_name(SessionPhase p);

struct AdvanceResult {
    bool advanced = false;             // false: stalled (window full, or lockstep waiting)
    std::uint32_t frame = 0;           // the displayed frame after this call
    std::uint32_t rollback_depth = 0;  // frames resimulated first (0: no rollback)
    int wait_frames = 0;               // time sync: skip this many ticks to let peers catch up
    int blocking_player = -1;          // when stalled: the remote player whose input is missing
    std::uint64_t resim_ns = 0;        // cpu time of the rollback, if any
    std::uint64_t forward_ns = 0;      // cpu time of the forward step, if any
    // Time sync for real-time loops: lengthen the next tick by this many parts per million
    // (0..100,000: 2 % per frame ahead) so peers behind catch up without a visible skip. wait_frames is the same advice
    // as whole ticks, for virtual-time loops.
    int tick_stretch_ppm = 0;
};

// One datagram a session wants sent (poll()), addressed by peer id.
struct Datagram {
    PlayerId peer = 0;
    std::vector<std::uint8_t> bytes;
    // Control and snapshot messages: a transport with a reliable channel should use it (the
    // session re-asks what is lost anyway, so an unreliable one works too).
    bool reliable = false;
};

}  // namespace lockroll::rollback
